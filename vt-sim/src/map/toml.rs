//! Obstacle lists in TOML (docs/planning.md, "Map files"):
//!
//! ```toml
//! bounds_m = [0.0, 50.0, -10.0, 10.0]          # x_min, x_max, y_min, y_max
//! [[circles]]
//! center_m = [16.0, 6.6]
//! radius_m = 1.6
//! [[polygons]]                                  # convex or not, either orientation
//! vertices_m = [[20.0, 0.0], [24.0, 0.0], [22.0, 3.0]]
//! [[walls]]                                     # a segment with a full thickness
//! from_m = [30.0, -10.0]
//! to_m = [30.0, -4.0]
//! thickness_m = 0.3
//! ```

use super::{nth_table_line, Map, Shape};
use crate::scenario::ScenarioError;
use serde::Deserialize;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    bounds_m: [f64; 4],
    #[serde(default)]
    circles: Vec<Circle>,
    #[serde(default)]
    polygons: Vec<Polygon>,
    #[serde(default)]
    walls: Vec<Wall>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Circle {
    center_m: [f64; 2],
    radius_m: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Polygon {
    vertices_m: Vec<[f64; 2]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Wall {
    from_m: [f64; 2],
    to_m: [f64; 2],
    thickness_m: f64,
}

fn finite(p: &[f64]) -> bool {
    p.iter().all(|x| x.is_finite())
}

/// Parses a TOML obstacle list.
///
/// # Errors
/// Syntax and type errors with their line; bad bounds, radii, thicknesses and polygons with the
/// line of their table.
pub fn parse(text: &str, source_name: &str) -> Result<Map, ScenarioError> {
    let err = |line: Option<usize>, field: String, message: String| ScenarioError {
        source_name: source_name.into(),
        line,
        field: Some(field),
        message,
    };
    let f: File = ::toml::from_str(text).map_err(|e| ScenarioError {
        source_name: source_name.into(),
        line: e.span().map(|s| text.get(..s.start.min(text.len())).map_or(0, |t| t.matches('\n').count()) + 1),
        field: None,
        message: e.message().trim().to_string(),
    })?;
    let b = f.bounds_m;
    if !(finite(&b) && b[0] < b[1] && b[2] < b[3]) {
        let line = text.lines().position(|l| l.trim_start().starts_with("bounds_m")).map(|i| i + 1);
        return Err(err(line, "bounds_m".into(), "must be finite [x_min, x_max, y_min, y_max] with min < max (the map is empty)".into()));
    }
    let mut shapes = Vec::new();
    for (i, c) in f.circles.iter().enumerate() {
        let line = nth_table_line(text, "circles", i);
        if !finite(&c.center_m) {
            return Err(err(line, format!("circles[{i}].center_m"), "must be finite".into()));
        }
        if !(c.radius_m.is_finite() && c.radius_m > 0.0) {
            return Err(err(line, format!("circles[{i}].radius_m"), format!("must be a finite number > 0 (got {})", c.radius_m)));
        }
        shapes.push(Shape::Circle { center_m: c.center_m, radius_m: c.radius_m });
    }
    for (i, p) in f.polygons.iter().enumerate() {
        let line = nth_table_line(text, "polygons", i);
        if p.vertices_m.len() < 3 || !p.vertices_m.iter().all(|v| finite(v)) {
            return Err(err(line, format!("polygons[{i}].vertices_m"), "needs at least 3 finite vertices".into()));
        }
        shapes.push(Shape::Polygon(p.vertices_m.clone()));
    }
    for (i, w) in f.walls.iter().enumerate() {
        let line = nth_table_line(text, "walls", i);
        if !(finite(&w.from_m) && finite(&w.to_m)) {
            return Err(err(line, format!("walls[{i}]"), "ends must be finite".into()));
        }
        if !(w.thickness_m.is_finite() && w.thickness_m > 0.0) {
            return Err(err(line, format!("walls[{i}].thickness_m"), format!("must be a finite number > 0 (got {})", w.thickness_m)));
        }
        shapes.push(Shape::Wall { from_m: w.from_m, to_m: w.to_m, thickness_m: w.thickness_m });
    }
    Ok(Map::Geometric { bounds_m: b, shapes })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_and_errors_with_lines() {
        let ok = "bounds_m = [0, 10, 0, 10]\n[[circles]]\ncenter_m = [1, 1]\nradius_m = 0.5\n[[polygons]]\nvertices_m = [[2, 2], [3, 2], [3, 3]]\n[[walls]]\nfrom_m = [5, 0]\nto_m = [5, 4]\nthickness_m = 0.2\n";
        let Map::Geometric { shapes, .. } = parse(ok, "m.toml").unwrap() else { panic!() };
        assert_eq!(shapes.len(), 3);
        let bad = ok.replace("radius_m = 0.5", "radius_m = -1");
        let e = parse(&bad, "m.toml").unwrap_err();
        assert_eq!(e.to_string(), "m.toml:2: `circles[0].radius_m`: must be a finite number > 0 (got -1)");
        let e = parse("bounds_m = [0, 0, 0, 1]\n", "m.toml").unwrap_err();
        assert!(e.to_string().starts_with("m.toml:1: `bounds_m`:"), "{e}");
        let e = parse("bounds_m = [0, 1, 0, 1]\n[[walls]]\nfrom_m = [0, 0]\n", "m.toml").unwrap_err();
        assert!(e.to_string().starts_with("m.toml:2:") && e.to_string().contains("to_m"), "{e}");
    }
}
