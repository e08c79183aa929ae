//! Map files for tube planning (issue 16): TOML obstacle lists ([`toml`]) and ROS
//! `map_server` occupancy maps ([`ros`]), and the glue that runs `vt_plan::plan` on them.
//!
//! Errors are [`ScenarioError`]s, shown `file:line: `field`: message` (or `file: reason` for an
//! image), so every bad input exits 2 with its place named (docs/planning.md).

pub mod forest;
pub mod ros;
pub mod toml;

use crate::scenario::{Scenario, ScenarioError};
use std::path::Path;
use vt_plan::{ClearanceMap, GridMap, Obstacle, ObstacleMap, PlanError, PlanParams, PlannedTube, Vec2, Workspace};

/// Most lattice nodes the host planner allocates work space for (6 x 4 bytes each, 24 MB);
/// a larger map gets a coarser lattice (`vt_plan::Lattice::covering`).
pub const MAX_LATTICE_NODES: usize = 1 << 20;

/// One geometric obstacle, owned (the map file's form of `vt_plan::Obstacle`).
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// Vertical cylinder: centre `[x, y]` and radius, m.
    Circle {
        /// Centre, m.
        center_m: [f64; 2],
        /// Radius, m.
        radius_m: f64,
    },
    /// Simple polygon (convex or not), vertices in order, m.
    Polygon(Vec<[f64; 2]>),
    /// Segment with a full thickness, m.
    Wall {
        /// First end, m.
        from_m: [f64; 2],
        /// Second end, m.
        to_m: [f64; 2],
        /// Full thickness, m.
        thickness_m: f64,
    },
}

/// An occupancy grid and its distance transform.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Columns (east).
    pub width: usize,
    /// Rows (north; row 0 is the southern edge, the image's bottom row).
    pub height: usize,
    /// Cell side, m.
    pub resolution_m: f64,
    /// Lower-left corner of cell (0, 0), m.
    pub origin_m: [f64; 2],
    /// Occupied cells, row-major `j * width + i` (unknown cells count as occupied).
    pub occupied: Vec<bool>,
    /// Distance from each cell centre to the nearest occupied centre, cells.
    pub dist_cells: Vec<f32>,
}

/// A loaded map.
#[derive(Debug, Clone, PartialEq)]
pub enum Map {
    /// Geometric obstacles in a rectangle `[x_min, x_max, y_min, y_max]`, m.
    Geometric {
        /// The rectangle, m.
        bounds_m: [f64; 4],
        /// The obstacles.
        shapes: Vec<Shape>,
    },
    /// An occupancy grid.
    Grid(Grid),
}

/// A map with its source name.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedMap {
    /// File name, for messages.
    pub source_name: String,
    /// The map.
    pub map: Map,
}

fn v2(p: [f64; 2]) -> Vec2 {
    Vec2::new(p[0] as f32, p[1] as f32)
}

impl Grid {
    /// Builds the grid and runs the distance transform (F&H, `vt_plan::distance_transform`).
    ///
    /// # Errors
    /// A message when the grid is empty or wholly occupied.
    pub fn new(width: usize, height: usize, resolution_m: f64, origin_m: [f64; 2], occupied: Vec<bool>) -> Result<Self, String> {
        if width == 0 || height == 0 || occupied.len() != width * height {
            return Err("the map is empty (no cells)".into());
        }
        if occupied.iter().all(|&o| o) {
            return Err("the map has no free cell (all occupied or unknown)".into());
        }
        let mut dist_cells: Vec<f32> = occupied.iter().map(|&o| if o { 0.0 } else { f32::INFINITY }).collect();
        let n = width.max(height);
        let (mut line, mut v, mut z) = (vec![0.0f32; 3 * n + 1], vec![0usize; n + 1], vec![0.0f32; n + 2]);
        vt_plan::distance_transform(&mut dist_cells, width, height, &mut line, &mut v, &mut z).map_err(|e| e.to_string())?;
        Ok(Self { width, height, resolution_m, origin_m, occupied, dist_cells })
    }

    /// The planner's view of this grid.
    pub fn view(&self) -> GridMap<'_> {
        GridMap {
            dist_cells: &self.dist_cells,
            width: self.width,
            height: self.height,
            resolution_m: self.resolution_m as f32,
            origin_m: v2(self.origin_m),
        }
    }
}

/// Planner parameters for a team (docs/planning.md, "Width needed"): every section holds one
/// UAV clear of both boundaries' barrier activation zones, `r_active + safety distance`. This is
/// above Proposition 2's floor `r_safe + safety distance` (one UAV's footprint), which is all the
/// theory asks but which let the 3-UAV team break the 0.4 m UAV-UAV floor in 3 of 5 forest
/// flights (docs/planning.md); `min_half_width_m` overrides it (down to that floor). The tube keeps
/// `PlanParams::default().margin_m` (0.4 m) from every obstacle.
pub fn params_for(s: &Scenario) -> PlanParams {
    PlanParams { need_half_width_m: (s.controller.r_active_m + s.mission.safety_distance_m) as f32, ..PlanParams::default() }
}

/// Proposition 2's floor for a section's half-width: one UAV's safety radius plus the safety
/// distance, m.
pub fn prop2_half_width_m(s: &Scenario) -> f64 {
    s.controller.r_safe_m + s.mission.safety_distance_m
}

impl LoadedMap {
    /// Loads a map file: `.yaml`/`.yml` is a ROS `map_server` map, anything else TOML.
    ///
    /// # Errors
    /// Unreadable or invalid file, naming file, line and field.
    pub fn load(path: &Path) -> Result<Self, ScenarioError> {
        let name = path.display().to_string();
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        let text = std::fs::read_to_string(path)
            .map_err(|e| ScenarioError { source_name: name.clone(), line: None, field: None, message: format!("cannot read: {e}") })?;
        let map = if ext == "yaml" || ext == "yml" { ros::parse(&text, &name, path.parent())? } else { toml::parse(&text, &name)? };
        Ok(Self { source_name: name, map })
    }

    /// The map of a scenario's `[world]`: its bounds and circular obstacles.
    pub fn from_world(s: &Scenario, source_name: &str) -> Self {
        let shapes = s.world.obstacles.iter().map(|o| Shape::Circle { center_m: o.center_m, radius_m: o.radius_m }).collect();
        Self { source_name: source_name.into(), map: Map::Geometric { bounds_m: s.world.bounds_m, shapes } }
    }

    /// The map rectangle `[x_min, x_max, y_min, y_max]`, m.
    pub fn bounds_m(&self) -> [f64; 4] {
        match &self.map {
            Map::Geometric { bounds_m, .. } => *bounds_m,
            Map::Grid(g) => {
                let (w, h) = (g.width as f64 * g.resolution_m, g.height as f64 * g.resolution_m);
                [g.origin_m[0], g.origin_m[0] + w, g.origin_m[1], g.origin_m[1] + h]
            }
        }
    }

    /// Clearance at `p`, m (exact for shapes, the transform's lower bound for grids).
    pub fn clearance_m(&self, p: [f64; 2]) -> f32 {
        self.with_view(|m| m.clearance(v2(p)))
    }

    /// Plans a tube from `start` to `goal` (`vt_plan::plan`, work space allocated here).
    ///
    /// # Errors
    /// The planner's error (too narrow, bad terminals, ...).
    pub fn plan(&self, start_m: [f64; 2], goal_m: [f64; 2], params: &PlanParams) -> Result<PlannedTube, PlanError> {
        self.with_view(|m| plan_on(m, v2(start_m), v2(goal_m), params))
    }

    fn with_view<R>(&self, f: impl FnOnce(&dyn DynClearance) -> R) -> R {
        match &self.map {
            Map::Geometric { bounds_m, shapes } => {
                let polys: Vec<Vec<Vec2>> = shapes.iter().map(|s| match s {
                    Shape::Polygon(v) => v.iter().map(|p| v2(*p)).collect(),
                    _ => Vec::new(),
                }).collect();
                let obstacles: Vec<Obstacle<'_>> = shapes.iter().zip(&polys).map(|(s, poly)| match s {
                    Shape::Circle { center_m, radius_m } => Obstacle::Circle { center_m: v2(*center_m), radius_m: *radius_m as f32 },
                    Shape::Wall { from_m, to_m, thickness_m } => {
                        Obstacle::Wall { a_m: v2(*from_m), b_m: v2(*to_m), thickness_m: *thickness_m as f32 }
                    }
                    Shape::Polygon(_) => Obstacle::Polygon(poly),
                }).collect();
                let m = ObstacleMap {
                    min_m: Vec2::new(bounds_m[0] as f32, bounds_m[2] as f32),
                    max_m: Vec2::new(bounds_m[1] as f32, bounds_m[3] as f32),
                    obstacles: &obstacles,
                };
                f(&m)
            }
            Map::Grid(g) => f(&g.view()),
        }
    }
}

/// Object-safe view of a clearance map (so one closure serves both map kinds).
trait DynClearance {
    fn bounds(&self) -> (Vec2, Vec2);
    fn clearance(&self, p: Vec2) -> f32;
    fn clearance_capped(&self, p: Vec2, cap: f32) -> f32;
}

impl<M: ClearanceMap> DynClearance for M {
    fn bounds(&self) -> (Vec2, Vec2) {
        self.bounds_m()
    }
    fn clearance(&self, p: Vec2) -> f32 {
        self.clearance_m(p)
    }
    fn clearance_capped(&self, p: Vec2, cap: f32) -> f32 {
        self.clearance_capped_m(p, cap)
    }
}

/// Forwards to the map behind the reference (explicit deref: the blanket impl above also covers
/// `&dyn DynClearance` itself, and a method call on `self` would pick it and loop).
struct DynMap<'a>(&'a dyn DynClearance);

impl ClearanceMap for DynMap<'_> {
    fn bounds_m(&self) -> (Vec2, Vec2) {
        self.0.bounds()
    }
    fn clearance_m(&self, p_m: Vec2) -> f32 {
        self.0.clearance(p_m)
    }
    fn clearance_capped_m(&self, p_m: Vec2, cap_m: f32) -> f32 {
        self.0.clearance_capped(p_m, cap_m)
    }
}

/// Runs the planner with work space for the map's lattice.
fn plan_on(m: &dyn DynClearance, start: Vec2, goal: Vec2, params: &PlanParams) -> Result<PlannedTube, PlanError> {
    let (lo, hi) = m.bounds();
    let size = hi - lo;
    let h = params.lattice_m.max(1e-3);
    let nodes = ((size.x / h).max(0.0) as usize + 1).saturating_mul((size.y / h).max(0.0) as usize + 1);
    let cap = nodes.clamp(4, MAX_LATTICE_NODES);
    let (mut floats, mut ints, mut steps) = (vec![0.0f32; 3 * cap], vec![0u32; 2 * cap], vec![0u8; Workspace::<u32>::parent_bytes(cap)]);
    vt_plan::plan(&DynMap(m), start, goal, params, &mut Workspace::new(&mut floats, &mut ints, &mut steps))
}

/// The planned tube as a scenario `[tube]` table (TOML), with the bottleneck as a comment.
pub fn tube_toml(t: &PlannedTube, map_name: &str, start: [f64; 2], goal: [f64; 2]) -> String {
    let b = &t.bottleneck;
    let mut s = format!(
        "# Planned by `host-sim plan` on {map_name} from ({}, {}) to ({}, {}).\n# Bottleneck: half-width {:.3} m at ({:.2}, {:.2}), s = {:.2} m.\n[tube]\nwaypoints = [\n",
        start[0], start[1], goal[0], goal[1], b.half_width_m, b.pos_m.x, b.pos_m.y, b.s_m
    );
    for w in &t.waypoints {
        // Widths are rounded down to the millimetre so the file never widens the planned tube.
        let fl = |x: f32| (f64::from(x) * 1000.0).floor() / 1000.0;
        s.push_str(&format!("  [{}, {}, {}, {}],\n", w.pos_m.x, w.pos_m.y, fl(w.w_left_m), fl(w.w_right_m)));
    }
    s.push_str("]\n");
    s
}

/// Line of the `index`-th `[[table]]` header in `text`, 1-based.
pub(crate) fn nth_table_line(text: &str, table: &str, index: usize) -> Option<usize> {
    let header = format!("[[{table}]]");
    text.lines().enumerate().filter(|(_, l)| l.trim().starts_with(&header)).nth(index).map(|(i, _)| i + 1)
}
