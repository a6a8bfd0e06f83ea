//! [`Settings::validate`]: every setting checked in one place before any file or GPU work,
//! so bad input gives one clear error line naming the flag (`--width 0: ...`) instead of a
//! panic deep inside wgpu. Each row of the run settings' table checks its own range
//! ([`crate::table::check_rows`]) and each row of the pass settings' its own
//! (`Knobs::check`); what relates two settings is checked here.
//!
//! Pure data, reads no file but a scene path's kind: depends on [`crate::settings`],
//! [`crate::table`] and the scene crate's limits.

use anyhow::{ensure, Result};
use tiledlight_gpu::culling::CLUSTER_TILE_SIZES;
use tiledlight_scene::MAX_LIGHTS;

use crate::settings::{LightPlacement, PeerScene, Raster, SceneSource, Settings};

impl Settings {
    /// Checks every setting's range; the error names the flag, its value and the limit.
    pub fn validate(&self) -> Result<()> {
        if let Some(d) = self.demo.filter(|_| self.scene != SceneSource::Default) {
            anyhow::bail!(
                "--demo {} dresses the built-in courtyard; it cannot be used with --scene {}",
                d.name(),
                self.scene
            );
        }
        // Each row of the run settings' table checks its own range (`crate::table`); what
        // relates two settings is checked below.
        crate::table::check_rows(self).map_err(anyhow::Error::msg)?;
        self.knobs.check().map_err(anyhow::Error::msg)?;
        if self.knobs.raster == Raster::Compute {
            ensure!(
                self.method.uses_visibility_buffer(),
                "--raster compute: the compute raster draws the visibility buffer only (--method visibility or \
                 traced-reference), not {}",
                self.method.name()
            );
            ensure!(
                self.msaa == 1,
                "--raster compute draws one sample a pixel: --msaa {} needs --raster hardware",
                self.msaa
            );
        }
        if self.method.traits().stochastic {
            // Also refused where the pass is built; checked here so that a sweep or the
            // tuner learns it from the settings alone, before any GPU work.
            ensure!(
                self.msaa == 1,
                "--method stochastic shades one sample a pixel: --msaa {} is not supported, use --msaa 1",
                self.msaa
            );
            ensure!(
                self.vpl.is_none(),
                "--method stochastic does not sample VPLs yet: render it without --vpl (the traced reference adds \
                 them unshadowed)"
            );
        }
        ensure!(self.grid_pairs != Some(0), "--grid-budget 0: the light grid must hold at least one index");
        ensure!(!(self.depth_mask && self.half_z), "--grid 2.5d with --half-z: they are alternative layouts, pick one");
        if let Some(c) = &self.clusters {
            ensure!(!self.half_z, "--grid clustered with --half-z: clusters slice depth themselves");
            ensure!(
                CLUSTER_TILE_SIZES.contains(&c.tile_size),
                "--cluster-tile {}: must be one of {CLUSTER_TILE_SIZES:?} pixels",
                c.tile_size
            );
            ensure!((1..=32).contains(&c.slices), "--cluster-slices {}: must be 1 to 32", c.slices);
            ensure!(
                c.first.is_finite() && c.first > 0.0,
                "--cluster-first {}: must be a positive distance in metres",
                c.first
            );
            ensure!(
                c.last.is_finite() && c.last > c.first,
                "--cluster-last {}: must be finite and beyond --cluster-first {}",
                c.last,
                c.first
            );
        }
        let (points, spots) = self.random_light_counts();
        ensure!(
            points + spots <= MAX_LIGHTS,
            "--lights {points} plus --spot-lights {spots}: at most {MAX_LIGHTS} lights in total are supported"
        );
        if let LightPlacement::Surfaces { lights_per_point: k } = self.placement {
            ensure!(k.is_finite() && k > 0.0, "--lights-per-pixel {k}: must be a positive number");
        }
        ensure!(
            self.exposure.is_finite() && self.exposure > 0.0,
            "--exposure {}: must be a positive number",
            self.exposure
        );
        match &self.scene {
            SceneSource::Default => ensure!(
                self.transparent_objects <= self.grid_objects,
                "--transparent-objects {}: must be between 0 and the grid objects (--grid-objects {})",
                self.transparent_objects,
                self.grid_objects
            ),
            SceneSource::File(_) | SceneSource::Peer(_) | SceneSource::Materials => ensure!(
                self.transparent_objects == 0,
                "--transparent-objects {}: transparent grid objects exist only in the default scene (a glTF \
                 file's BLEND materials are drawn blended on their own)",
                self.transparent_objects
            ),
        }
        ensure!(
            !self.emissive || self.scene == SceneSource::Default,
            "--emissive: the glowing banners exist only in the default scene (a glTF file's emissive materials \
             glow on their own)"
        );
        if let Some(v) = &self.vpl {
            ensure!(
                self.has_shadows(),
                "--vpl: VPLs are made from the shadow-casting lights' reflective shadow maps; give \
                 --shadow-spot-lights or --shadow-point-lights"
            );
            v.validate().map_err(|e| anyhow::anyhow!("--vpl: {e}"))?;
        }
        // The default scene's lights are all random, so their counts are known here; a glTF
        // file's own lights are counted when it is loaded (the upload checks the casters).
        // A demo's own lights (the dressing) come on top of the random ones.
        if self.scene == SceneSource::Default {
            let (demo_points, demo_spots) = self.demo.map_or((0, 0), |d| d.light_counts());
            let casters = [
                ("--shadow-point-lights", self.shadow_point_lights, "point", "--lights", points, demo_points),
                ("--shadow-spot-lights", self.shadow_spot_lights, "spot", "--spot-lights", spots, demo_spots),
            ];
            for (flag, n, kind, count_flag, random, own) in casters {
                let count = random + own;
                let demo = match self.demo {
                    Some(d) if own > 0 => format!(" and --demo {}'s {own}", d.name()),
                    _ => String::new(),
                };
                ensure!(
                    u64::from(n) <= count,
                    "{flag} {n}: more than the scene's {count} {kind} lights ({count_flag} {random}{demo})"
                );
            }
        }
        {
            use tiledlight_scene::materials::DEFAULT_MATERIALS;
            ensure!(
                self.materials == DEFAULT_MATERIALS || self.scene == SceneSource::Materials,
                "--materials {}: only the many-material scene has them (--scene materials)",
                self.materials
            );
        }
        if self.scene == SceneSource::Materials {
            ensure!(
                self.grid_objects == 0,
                "--grid-objects {}: grid objects exist only in the default scene (--scene materials has its boxes)",
                self.grid_objects
            );
        }
        if let SceneSource::Peer(p) = self.scene {
            ensure!(
                self.grid_objects == 0,
                "--grid-objects {}: grid objects exist only in the default scene (--scene {} has its own)",
                self.grid_objects,
                p.name()
            );
        }
        if let SceneSource::File(path) = &self.scene {
            let built_in = || {
                let peers: Vec<&str> = PeerScene::ALL.iter().map(|p| p.name()).collect();
                format!("'default', 'materials', '{}'", peers.join("', '"))
            };
            ensure!(
                !path.is_dir(),
                "--scene {}: is a folder; give the .gltf or .glb file inside it, or a built-in scene: {}",
                path.display(),
                built_in()
            );
            let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
            ensure!(
                matches!(ext.as_deref(), Some("gltf" | "glb")),
                "--scene {}: expected a .gltf or .glb file, or a built-in scene: {}",
                path.display(),
                built_in()
            );
            ensure!(
                self.grid_objects == 0,
                "--grid-objects {}: grid objects exist only in the default scene",
                self.grid_objects
            );
        }
        // No check of list memory by screen size: the light grid is sized from the frame's
        // pairs (8 bytes a list plus the indices found), so a 16384x16384 frame with few
        // lights needs a few MiB; the GPU checks its binding limits itself.
        Ok(())
    }
}
