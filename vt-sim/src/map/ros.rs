//! ROS `map_server` occupancy maps: a YAML file plus its PGM or PNG image
//! (<http://wiki.ros.org/map_server>, "Map format").
//!
//! ```yaml
//! image: yard.pgm
//! resolution: 0.1              # m per pixel
//! origin: [-2.0, -10.0, 0.0]   # lower-left pixel's corner [x, y, yaw]
//! occupied_thresh: 0.65
//! free_thresh: 0.196
//! negate: 0
//! mode: trinary                # optional: trinary (default), scale, raw
//! ```
//!
//! A pixel's occupancy is `p = (255 - v) / 255` (`v / 255` when `negate` is set), `v` its grey
//! level (colour images are converted to luma, alpha ignored). `p > occupied_thresh` is
//! occupied, `p < free_thresh` free, anything between unknown; in `raw` mode `v` itself is the
//! occupancy in percent. Unknown counts as occupied (the planner stays in known free space).
//! The image's top row is the map's northern edge. Rotated maps (`yaw != 0`) are refused.

use super::{Grid, Map};
use crate::scenario::ScenarioError;
use serde::Deserialize;
use std::path::Path;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    image: String,
    resolution: f64,
    origin: Vec<f64>,
    occupied_thresh: f64,
    free_thresh: f64,
    negate: Negate,
    #[serde(default)]
    mode: Option<String>,
}

/// `negate` is written `0`/`1` by map_server and `true`/`false` by some tools.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum Negate {
    Int(i64),
    Bool(bool),
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    Trinary,
    Scale,
    Raw,
}

/// Parses a map_server YAML and loads its image from `dir` (the YAML's folder).
///
/// # Errors
/// YAML syntax and type errors with their line; bad fields with the line of their key;
/// an unreadable or undecodable image as `image: reason`.
pub fn parse(text: &str, source_name: &str, dir: Option<&Path>) -> Result<Map, ScenarioError> {
    let err = |key: &str, message: String| ScenarioError {
        source_name: source_name.into(),
        line: text.lines().position(|l| l.trim_start().starts_with(&format!("{key}:"))).map(|i| i + 1),
        field: Some(key.into()),
        message,
    };
    let f: File = serde_norway::from_str(text).map_err(|e| ScenarioError {
        source_name: source_name.into(),
        line: e.location().map(|l| l.line()),
        field: None,
        message: e.to_string(),
    })?;
    if !(f.resolution.is_finite() && f.resolution > 0.0) {
        return Err(err("resolution", format!("must be a finite number > 0 (got {})", f.resolution)));
    }
    if f.origin.len() != 3 || !f.origin.iter().all(|x| x.is_finite()) {
        return Err(err("origin", "must be three finite numbers [x, y, yaw]".into()));
    }
    if f.origin.get(2).is_some_and(|&yaw| yaw != 0.0) {
        return Err(err("origin", "rotated maps (yaw != 0) are not supported".into()));
    }
    if !(f.free_thresh.is_finite() && f.occupied_thresh.is_finite() && 0.0 <= f.free_thresh && f.free_thresh < f.occupied_thresh && f.occupied_thresh <= 1.0) {
        let key = if (0.0..=1.0).contains(&f.free_thresh) { "occupied_thresh" } else { "free_thresh" };
        return Err(err(key, format!(
            "thresholds out of order: need 0 <= free_thresh < occupied_thresh <= 1 (got free {}, occupied {})",
            f.free_thresh, f.occupied_thresh)));
    }
    let negate = match f.negate {
        Negate::Int(0) | Negate::Bool(false) => false,
        Negate::Int(1) | Negate::Bool(true) => true,
        Negate::Int(n) => return Err(err("negate", format!("must be 0 or 1 (got {n})"))),
    };
    let mode = match f.mode.as_deref() {
        None | Some("trinary") => Mode::Trinary,
        Some("scale") => Mode::Scale,
        Some("raw") => Mode::Raw,
        Some(m) => return Err(err("mode", format!("must be trinary, scale or raw (got {m:?})"))),
    };
    let image_path = dir.map_or_else(|| Path::new(&f.image).to_path_buf(), |d| d.join(&f.image));
    let image_name = image_path.display().to_string();
    let img_err = |reason: String| ScenarioError { source_name: image_name.clone(), line: None, field: None, message: reason };
    let img = image::open(&image_path).map_err(|e| img_err(format!("cannot load the map image: {e}")))?.to_luma8();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let mut occupied = vec![true; w * h];
    for (x, y, px) in img.enumerate_pixels() {
        let v = f64::from(px.0[0]);
        let occ = match mode {
            Mode::Raw => v > 100.0 || v / 100.0 >= f.free_thresh, // > 100: unknown (255 in map_server)
            Mode::Trinary | Mode::Scale => {
                let p = if negate { v / 255.0 } else { (255.0 - v) / 255.0 };
                // Unknown (between the thresholds) is occupied for planning.
                p >= f.free_thresh
            }
        };
        // Image row 0 is the top (north); grid row 0 is the bottom.
        let j = h - 1 - y as usize;
        if let Some(c) = occupied.get_mut(j * w + x as usize) {
            *c = occ;
        }
    }
    let grid = Grid::new(w, h, f.resolution, [f.origin[0], f.origin[1]], occupied).map_err(img_err)?;
    Ok(Map::Grid(grid))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write_map(dir: &Path, yaml: &str, pixels: &[u8], w: u32, h: u32) -> std::path::PathBuf {
        std::fs::create_dir_all(dir).unwrap();
        image::GrayImage::from_raw(w, h, pixels.to_vec()).unwrap().save(dir.join("m.png")).unwrap();
        let p = dir.join("m.yaml");
        std::fs::write(&p, yaml).unwrap();
        p
    }

    const YAML: &str = "image: m.png\nresolution: 0.5\norigin: [1.0, 2.0, 0.0]\noccupied_thresh: 0.65\nfree_thresh: 0.196\nnegate: 0\n";

    #[test]
    fn pixels_map_to_cells_north_up_and_errors_name_the_field() {
        let dir = std::env::temp_dir().join(format!("vt-ros-map-{}", std::process::id()));
        // 3 x 2 image: top row black at x = 0 (occupied), grey unknown at x = 2, rest white.
        let p = write_map(&dir, YAML, &[0, 254, 128, 254, 254, 254], 3, 2);
        let text = std::fs::read_to_string(&p).unwrap();
        let Map::Grid(g) = parse(&text, "m.yaml", Some(&dir)).unwrap() else { panic!() };
        assert_eq!((g.width, g.height, g.origin_m), (3, 2, [1.0, 2.0]));
        // Top image row = grid row 1.
        assert_eq!(g.occupied, vec![false, false, false, true, false, true]);
        for (bad, field) in [
            (YAML.replace("resolution: 0.5", "resolution: 0"), "resolution"),
            (YAML.replace("free_thresh: 0.196", "free_thresh: 0.9"), "occupied_thresh"),
            (YAML.replace("negate: 0", "negate: 3"), "negate"),
        ] {
            let e = parse(&bad, "m.yaml", Some(&dir)).unwrap_err();
            assert_eq!(e.field.as_deref(), Some(field), "{e}");
            assert!(e.line.is_some(), "{e}");
        }
        let e = parse(&YAML.replace("m.png", "nope.png"), "m.yaml", Some(&dir)).unwrap_err();
        assert!(e.source_name.ends_with("nope.png") && e.line.is_none(), "{e}");
        let p = write_map(&dir, YAML, &[0; 6], 3, 2);
        let e = parse(&std::fs::read_to_string(&p).unwrap(), "m.yaml", Some(&dir)).unwrap_err();
        assert!(e.message.contains("no free cell"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
