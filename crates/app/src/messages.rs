//! One-line messages: every failure of the command line is a single `error:` line, every
//! partial result a single `warning:` line, whatever the error's text (wgpu validation
//! errors and clap's usage hints span lines). Used by the subcommands and the viewer.
//! Depends on anyhow and tiledlight-lab (whose `output::one_line` the lab shares).

pub use tiledlight_lab::output::one_line;

/// The error and its causes on one line, "context: cause: cause", leaving out a cause
/// whose text the line already holds (some errors print their source in their own
/// message, which anyhow's `{:#}` would repeat).
pub fn error_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = one_line(&cause.to_string());
        if line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}
