//! Camera bookmarks: a small text file that pins a view so it can be reproduced, written
//! by the viewer ("save camera", key C) and read by `render`, `bench` and `view` through
//! `--camera FILE`. One `key values...` line each, `#` starts a comment:
//!
//! ```text
//! # tiledlight camera bookmark
//! eye 12.5 3 -4.25
//! target 0 1.5 0
//! up 0 1 0
//! fov_y_deg 60
//! near 0.05
//! far inf
//! ```
//!
//! `eye`, `target` and `fov_y_deg` are required; `up` defaults to +Y, `near` to 0.1 and
//! `far` to `inf` (an infinite far plane). Numbers are written with Rust's shortest
//! round-trip formatting, so saving and loading gives back the same floats. Errors name
//! the file and line. Depends on glam and tiledlight-scene (`CameraDesc`) only.

use std::path::Path;

use anyhow::{bail, Context, Result};
use glam::Vec3;
use tiledlight_scene::CameraDesc;

/// Near plane used when a bookmark has no `near` line.
pub const DEFAULT_NEAR: f32 = 0.1;

/// The bookmark text of `c`.
pub fn format(c: &CameraDesc) -> String {
    let v = |v: Vec3| format!("{} {} {}", v.x, v.y, v.z);
    let far = c.far.map_or_else(|| "inf".to_string(), |f| f.to_string());
    format!(
        "# tiledlight camera bookmark (use with --camera FILE)\neye {}\ntarget {}\nup {}\nfov_y_deg {}\nnear {}\nfar {far}\n",
        v(c.eye),
        v(c.target),
        v(c.up),
        c.fov_y.to_degrees(),
        c.near
    )
}

/// Parses bookmark text; `name` (the file) prefixes every error with the line number.
pub fn parse(text: &str, name: &str) -> Result<CameraDesc> {
    let (mut eye, mut target, mut up, mut fov, mut near, mut far) = (None, None, None, None, None, None);
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let at = || format!("{name}:{}", i + 1);
        let mut words = line.split_whitespace();
        let key = words.next().unwrap_or_default();
        let values: Vec<&str> = words.collect();
        let number = |s: &str, allow_inf: bool| -> Result<f32> {
            let x: f32 = s.parse().map_err(|_| anyhow::anyhow!("{}: '{s}' is not a number", at()))?;
            if x.is_nan() || (x.is_infinite() && !allow_inf) {
                bail!("{}: '{s}' must be a finite number", at());
            }
            Ok(x)
        };
        let count = |n: usize| -> Result<()> {
            if values.len() != n {
                bail!("{}: '{key}' takes {n} number{}, found {}", at(), if n == 1 { "" } else { "s" }, values.len());
            }
            Ok(())
        };
        let vec3 = || -> Result<Vec3> {
            count(3)?;
            Ok(Vec3::new(number(values[0], false)?, number(values[1], false)?, number(values[2], false)?))
        };
        let slot_taken = match key {
            "eye" => eye.replace(vec3()?).is_some(),
            "target" => target.replace(vec3()?).is_some(),
            "up" => up.replace(vec3()?).is_some(),
            "fov_y_deg" => {
                count(1)?;
                let f = number(values[0], false)?;
                if !(f > 0.0 && f < 180.0) {
                    bail!("{}: fov_y_deg {f} must be between 0 and 180 degrees", at());
                }
                fov.replace(f.to_radians()).is_some()
            }
            "near" => {
                count(1)?;
                let n = number(values[0], false)?;
                if n <= 0.0 {
                    bail!("{}: near {n} must be positive", at());
                }
                near.replace(n).is_some()
            }
            "far" => {
                count(1)?;
                let f = number(values[0], true)?;
                far.replace(if f.is_infinite() && f > 0.0 { None } else { Some(f) }).is_some()
            }
            _ => bail!("{}: unknown key '{key}' (expected eye, target, up, fov_y_deg, near, far)", at()),
        };
        if slot_taken {
            bail!("{}: '{key}' given twice", at());
        }
    }
    let missing = |what: &str| anyhow::anyhow!("{name}: no '{what}' line");
    let desc = CameraDesc {
        eye: eye.ok_or_else(|| missing("eye"))?,
        target: target.ok_or_else(|| missing("target"))?,
        up: up.unwrap_or(Vec3::Y),
        fov_y: fov.ok_or_else(|| missing("fov_y_deg"))?,
        near: near.unwrap_or(DEFAULT_NEAR),
        far: far.unwrap_or(None),
    };
    if let Some(f) = desc.far {
        if f <= desc.near {
            bail!("{name}: far {f} must be beyond near {}", desc.near);
        }
    }
    if (desc.target - desc.eye).length_squared() == 0.0 {
        bail!("{name}: eye and target are the same point");
    }
    Ok(desc)
}

/// Reads and parses the bookmark at `path`.
pub fn load(path: &Path) -> Result<CameraDesc> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("--camera {}: cannot read the file", path.display()))?;
    parse(&text, &path.display().to_string())
}

/// Writes `c` as a bookmark to `path`, creating its directory.
pub fn save(path: &Path, c: &CameraDesc) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating directory {}", dir.display()))?;
    }
    std::fs::write(path, format(c)).with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn desc() -> CameraDesc {
        CameraDesc {
            eye: Vec3::new(12.5, 3.1, -4.0e-3),
            target: Vec3::new(0.0, 1.0 / 3.0, 0.0),
            up: Vec3::Y,
            fov_y: 61.3f32.to_radians(),
            near: 0.05,
            far: None,
        }
    }

    fn err(text: &str) -> String {
        format!("{:#}", parse(text, "cam.txt").unwrap_err())
    }

    #[test]
    fn round_trip_is_exact() {
        for far in [None, Some(1234.5)] {
            let d = CameraDesc { far, ..desc() };
            let back = parse(&format(&d), "x").unwrap();
            assert_eq!(back, d);
        }
    }

    #[test]
    fn defaults_and_comments() {
        let d = parse("# view\neye 0 1 5  # behind\ntarget 0 1 0\n\nfov_y_deg 45\n", "x").unwrap();
        assert_eq!((d.up, d.near, d.far), (Vec3::Y, DEFAULT_NEAR, None));
        assert!((d.fov_y - 45f32.to_radians()).abs() < 1e-7);
    }

    #[test]
    fn malformed_lines_name_file_and_line() {
        assert!(err("eye 0 1\n").contains("cam.txt:1: 'eye' takes 3 numbers, found 2"));
        assert!(err("eye 0 0 1\ntarget 0 x 0\n").contains("cam.txt:2: 'x' is not a number"));
        assert!(err("eye 0 0 1\nzoom 3\n").contains("cam.txt:2: unknown key 'zoom'"));
        assert!(err("eye 0 0 1\neye 0 0 2\n").contains("cam.txt:2: 'eye' given twice"));
        assert!(err("eye 0 0 1\ntarget 0 0 0\n").contains("no 'fov_y_deg' line"));
        assert!(err("eye 0 0 1\ntarget 0 0 0\nfov_y_deg 190\n").contains("cam.txt:3: fov_y_deg 190"));
        assert!(err("eye 0 0 1\ntarget 0 0 1\nfov_y_deg 60\n").contains("same point"));
        assert!(err("eye 0 0 1\ntarget 0 0 0\nfov_y_deg 60\nnear 2\nfar 1\n").contains("beyond near"));
    }

    #[test]
    fn nan_and_inf_are_rejected() {
        assert!(err("eye NaN 0 1\n").contains("cam.txt:1: 'NaN' must be a finite number"));
        assert!(err("eye 0 0 1\ntarget inf 0 0\n").contains("cam.txt:2: 'inf' must be a finite number"));
        assert!(err("eye 0 0 1\ntarget 0 0 0\nfov_y_deg 60\nnear nan\n").contains("cam.txt:4"));
        assert!(err("eye 0 0 1\ntarget 0 0 0\nfov_y_deg 60\nfar NaN\n").contains("cam.txt:4"));
    }

    #[test]
    fn missing_file_is_a_clear_error() {
        let e = format!("{:#}", load(Path::new("/nonexistent/cam.txt")).unwrap_err());
        assert!(e.contains("--camera /nonexistent/cam.txt: cannot read the file"), "{e}");
    }

    /// The bookmarks shipped in `assets/cameras` (the tuner's views in
    /// `scripts/device-lab.sh tune-views`) parse, and each looks at its scene from inside
    /// the courtyard's bounds (eye within 20 m of the origin, a distinct target).
    #[test]
    fn the_shipped_bookmarks_parse() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/cameras");
        let mut n = 0;
        for e in std::fs::read_dir(&dir).expect("assets/cameras") {
            let c = load(&e.unwrap().path()).unwrap();
            assert!(c.eye.length() < 20.0 && c.eye.distance(c.target) > 1.0, "{c:?}");
            n += 1;
        }
        assert!(n >= 2, "{n} bookmarks");
    }
}
