//! tiledlight-lab: the measurement lab as a library, used by the app (`tiledlight bench`,
//! `sweep`, `accuracy`, `shadow-accuracy`, `peer-report`, `render`) and by the GPU tests.
//!
//! - [`mod@bench`]: the frame loop ([`bench::measure`], [`bench::measure_moving`],
//!   [`bench::render_frame`]), per-pass timing summaries, the table, the bench report's
//!   JSON schema ([`bench::ConfigJson`], shared with shadow-accuracy) and `bench` itself;
//! - [`axes`]: the settings a run varies ([`axes::Axis`], applied to any [`axes::Flags`]),
//!   the points of a run, the resumable CSV ([`axes::ResumableCsv`]) and the progress bar;
//! - [`sweep`]: per-pass GPU time over a grid of settings, CSV and chart;
//! - [`accuracy`]: time and image error against the brute-force reference per setting,
//!   the reference rendering and the culling lists' quality;
//! - [`shadow_accuracy`]: the shadow maps' error against a CPU ray-cast reference;
//! - [`peer_report`]: the peer benchmark's tables, chart and FLIP comparison;
//! - [`chart`] (line, bar and Pareto charts), [`legend`] (the heat map's legend);
//! - [`dropped`]: accounting of the work a full light grid dropped, and the warnings;
//! - [`tune`]: the fastest setting within an error budget (`tiledlight tune`);
//! - [`reference_cache`]: references kept on disk (`accuracy --reference-cache`);
//! - [`worst`]: a setting's worst pixel explained (where, both values, its largest lights);
//! - [`output`]: one-line messages, load warnings and PNG output.
//!
//! The CPU image helpers the labs use (the ACES tonemap twin, histogram matching, the
//! visibility error) are tiledlight-metrics', beside FLIP and the HDR errors.
//!
//! No command line here (no clap): the app converts its flags into the plain job structs
//! (`sweep::Sweep`, `accuracy::Accuracy`, ...) and implements [`axes::Flags`] for its
//! scene flags. Depends on tiledlight-setup (the run), tiledlight-gpu (timer, grids,
//! methods), tiledlight-frame (the renderer, shadow-accuracy's too), tiledlight-cull (CPU
//! culling and ray cast), tiledlight-scene (the shadow rays' geometry), tiledlight-metrics;
//! never on the app. Errors are `anyhow` errors
//! whose text is meant for the user (they name the app's flags).

pub mod accuracy;
pub mod axes;
pub mod bench;
pub mod chart;
pub mod dropped;
pub mod legend;
pub mod output;
pub mod peer_report;
pub mod reference_cache;
pub mod shadow_accuracy;
pub mod sweep;
pub mod tune;
pub mod worst;
