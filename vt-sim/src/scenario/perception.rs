//! Issue 28's scenario tables: `[perception]` (what the team knows of the map, how often it
//! re-plans), `[sensors.lidar]` (the range sensor, [`crate::lidar::LidarSpec`]) and
//! `[[world.appear]]` (obstacles that appear in flight). docs/scenario.md lists them.

use crate::lidar::LidarSpec;
use crate::map::Shape;
use serde::Deserialize;

/// What the team knows of the world before take-off (`[perception] map`).
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MapKnowledge {
    /// The tube is planned before take-off on the true map and flown as planned.
    #[default]
    Known,
    /// The team knows only the world's bounds, the start and the goal: it maps with its
    /// LiDARs and re-plans in flight.
    Unknown,
}

/// `[perception]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PerceptionSpec {
    /// `known` (default) or `unknown`.
    #[serde(default)]
    pub map: MapKnowledge,
    /// Scheduled re-plans per second (default 1; newly seen obstacles in the tube ahead of the
    /// load trigger one at once).
    #[serde(default = "default_replan_hz")]
    pub replan_hz: f64,
    /// Cell side of the onboard occupancy map, m (default 0.25).
    #[serde(default = "default_cell")]
    pub cell_m: f64,
}

fn default_replan_hz() -> f64 {
    1.0
}
fn default_cell() -> f64 {
    0.25
}

impl Default for PerceptionSpec {
    fn default() -> Self {
        Self { map: MapKnowledge::Known, replan_hz: default_replan_hz(), cell_m: default_cell() }
    }
}

/// `[sensors]`: what each UAV carries beyond its autopilot's sensors.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SensorsSpec {
    /// A planar LiDAR on every UAV (absent: none).
    #[serde(default)]
    pub lidar: Option<LidarSpec>,
}

/// `[[world.appear]]`: an obstacle that appears at `time_s` (a circle, `center_m` and
/// `radius_m`, or a `polygon`).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AppearSpec {
    /// When it appears, s after the mission start.
    pub time_s: f64,
    /// Circle centre `[x, y]`, m.
    #[serde(default)]
    pub center_m: Option<[f64; 2]>,
    /// Circle radius, m.
    #[serde(default)]
    pub radius_m: Option<f64>,
    /// Polygon vertices `[[x, y], ...]`, m, in order.
    #[serde(default)]
    pub polygon: Option<Vec<[f64; 2]>>,
}

impl AppearSpec {
    /// The obstacle's shape, or the field that is wrong and why.
    pub fn shape(&self) -> Result<Shape, (&'static str, String)> {
        if !(self.time_s.is_finite() && self.time_s >= 0.0) {
            return Err(("time_s", format!("must be a finite time >= 0 s (got {})", self.time_s)));
        }
        let finite = |p: &[f64; 2]| p[0].is_finite() && p[1].is_finite();
        match (&self.center_m, self.radius_m, &self.polygon) {
            (Some(c), Some(r), None) => {
                if !finite(c) {
                    return Err(("center_m", "must be finite".into()));
                }
                if !(r.is_finite() && r > 0.0) {
                    return Err(("radius_m", format!("must be a finite number > 0 (got {r})")));
                }
                Ok(Shape::Circle { center_m: *c, radius_m: r })
            }
            (None, None, Some(p)) => {
                if p.len() < 3 || !p.iter().all(finite) {
                    return Err(("polygon", format!("needs at least 3 finite vertices (got {})", p.len())));
                }
                Ok(Shape::Polygon(p.clone()))
            }
            _ => Err(("center_m", "give either `center_m` and `radius_m` (a circle) or `polygon`".into())),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::scenario::{parse, MapKnowledge, ScenarioError};

    const PLANNED: &str = include_str!("../../../scenarios/paper-10uav-planned.toml");

    fn with(extra: &str) -> (String, Result<crate::scenario::LoadedScenario, ScenarioError>) {
        let text = format!("{PLANNED}\n{extra}");
        let r = parse(&text, "t.toml");
        (text, r)
    }

    fn line_of(text: &str, needle: &str) -> Option<usize> {
        text.lines().position(|l| l.contains(needle)).map(|i| i + 1)
    }

    #[test]
    fn an_unknown_map_flies_a_tube_planned_on_the_bounds_alone() {
        let (_, r) = with("[perception]\nmap = \"unknown\"\n\n[sensors.lidar]\nrange_m = 12.0\n");
        let ls = r.unwrap();
        assert_eq!(ls.scenario.perception.map, MapKnowledge::Unknown);
        assert_eq!(ls.scenario.sensors.lidar.as_ref().map(|l| l.range_m), Some(12.0));
        // On the bounds alone the tube is the straight line from start to goal (within the
        // planner's 0.25 m lattice).
        let w = &ls.scenario.tube.waypoints;
        let (a, b) = (w.first().unwrap(), w.last().unwrap());
        let straight = w.iter().all(|p| {
            let t = ((p[0] - a[0]) * (b[0] - a[0]) + (p[1] - a[1]) * (b[1] - a[1])) / ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2));
            let q = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
            (p[0] - q[0]).hypot(p[1] - q[1]) < 0.3
        });
        assert!(straight, "{w:?}");
        // The known map's plan is not straight: the obstacles bend it.
        let known = parse(PLANNED, "k.toml").unwrap();
        assert_ne!(known.scenario.tube.waypoints.len(), 0);
        assert!(known.scenario.tube.waypoints != *w);
    }

    #[test]
    fn bad_perception_tables_name_the_field_and_line() {
        let (text, r) = with("[perception]\nmap = \"unknown\"\n");
        let e = r.unwrap_err();
        assert_eq!((e.field.as_deref(), e.line), (Some("perception.map"), line_of(&text, "map = \"unknown\"")), "{e}");
        assert!(e.message.contains("[sensors.lidar]"), "{e}");
        let (text, r) = with("[sensors.lidar]\nbeams = 80\n");
        let e = r.unwrap_err();
        assert_eq!((e.field.as_deref(), e.line), (Some("sensors.lidar.beams"), line_of(&text, "beams = 80")), "{e}");
        let (text, r) = with("[perception]\ncell_m = 0.01\n");
        let e = r.unwrap_err();
        assert_eq!((e.field.as_deref(), e.line), (Some("perception.cell_m"), line_of(&text, "cell_m = 0.01")), "{e}");
        let (text, r) = with("[[world.appear]]\ntime_s = 5.0\ncenter_m = [20.0, 10.0]\nradius_m = 1.0\n\n[[world.appear]]\ntime_s = 8.0\ncenter_m = [20.0, 10.0]\npolygon = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]\n");
        let e = r.unwrap_err();
        assert_eq!(e.field.as_deref(), Some("world.appear[1].center_m"), "{e}");
        assert_eq!(e.line, line_of(&text, "time_s = 8.0").map(|l| l + 1), "{e}");
        let (_, r) = with("[[world.appear]]\ntime_s = -1.0\ncenter_m = [20.0, 10.0]\nradius_m = 1.0\n");
        assert_eq!(r.unwrap_err().field.as_deref(), Some("world.appear[0].time_s"));
        let (_, r) = with("[[world.appear]]\ntime_s = 5.0\ncenter_m = [20.0, 10.0]\nradius_m = 1.0\n");
        assert_eq!(r.unwrap().scenario.world.appear.len(), 1);
    }
}
