//! Tubes generated in flight (issue 28; the paper's future work): each companion fuses range
//! scans into its occupancy map (`vt_map`), the team's designated planner re-plans the tube on
//! it (`vt_plan`), and every companion takes a new tube only when it is safe to
//! (docs/design.md, "Tubes generated in flight").
//!
//! - **Who plans**: the lowest id among the healthy members (own data fresh, in the view):
//!   [`designated_planner`]. When it goes silent, the next id finds itself lowest and plans.
//! - **When**: every `1 / replan_hz`, and at once when a newly occupied cell lies in the current
//!   tube ahead of the load ([`Perception::integrate`] sets [`Perception::blocked`]).
//! - **Where from**: the new tube starts at the team's current section, [`BACKOFF_M`] behind
//!   the load along the current tube, so the whole formation starts inside it; it ends at the
//!   mission's goal.
//! - **Unknown cells are free**: the plan is optimistic and is corrected as the team sees more.
//! - **Accepting** ([`accept`]): a companion switches only when the new tube holds its own
//!   centre and the load's with the barrier no closer than before (or outside the activation
//!   band); otherwise it keeps the old one. The barrier term can only fall at a switch, so no
//!   UAV is suddenly "outside".
//!
//! The map and the planner's work space are sized for a 70 x 30 m world at 0.25 m
//! ([`MAP_CELLS`]); the planner reads the map's own cells as bits, one a cell, with exact
//! clearance queries (`vt_plan::OccupancyMap`) and no distance field.

use crate::{CompanionTube, Vec3};
use vt_tube::Waypoint;
use vt_map::{LogOddsParams, PackedOccupancyGrid, Scan, SectorFold};
use vt_plan::{OccupancyBits, OccupancyMap, PlanError, PlanParams, PlannedTube, Workspace};

/// Cells of the onboard map: 70 x 30 m at 0.25 m (issue 28's holdout-sized world).
pub const MAP_CELLS: usize = 33_600;
/// The onboard map: [`MAP_CELLS`] cells at four bits each (16.8 KB), exact for [`LOG_ODDS`]
/// (`vt_map::store`: the model reaches 14 log-odds values).
pub type OnboardMap = PackedOccupancyGrid<{ MAP_CELLS / 2 }>;
/// The onboard map's sensor model: OctoMap's hit and clamps, a sector's miss [`SECTOR_MISS`].
pub const LOG_ODDS: LogOddsParams = LogOddsParams { miss: SECTOR_MISS, ..LogOddsParams::OCTOMAP };
/// Words of the planner's grid: the map's own cells, a bit each (`OccupancyGrid::write_planner_bits`).
pub const PLAN_WORDS: usize = OccupancyBits::words(MAP_CELLS);
/// Lattice nodes of the planner's search (a coarser lattice is used when the map needs more).
pub const LATTICE_NODES: usize = 4_096;
/// From a re-plan to its tube at the team, ms: the flight MCU's budget for a full re-plan
/// (16.8 M instructions, 100 ms at 168 MHz; issue 28), in which the team flies on.
pub const HAND_OVER_MS: u32 = 100;
/// The new tube starts this far behind the load along the current tube, m.
pub const BACKOFF_M: f32 = 4.0;
/// A scheduled re-plan replaces a tube that nothing blocks only when it is at least this much
/// shorter (fraction of the current tube's remaining length): tubes are not churned for
/// centimetres, every switch is a step in the barrier.
pub const SHORTER_TO_SWITCH: f32 = 0.1;
/// Triggered re-plans come at most this often, ms (cells at an obstacle's edge flip as scans
/// arrive; a re-plan per scan would only repeat itself).
pub const MIN_REPLAN_GAP_MS: u32 = 200;
/// A failed re-plan holds the team when a known obstacle lies in its current tube less than
/// this far ahead of the load along it, m (the formation's front, a stop and a margin). A
/// bottleneck farther off is not final: the map there is seen from afar, through sectors
/// metres wide, and sharpens as the team comes closer, so the team flies on and re-plans.
pub const HOLD_AHEAD_M: f32 = 8.0;
/// The deceleration a stop is planned with, m/s^2 (a team hold brings the team to rest from
/// `v_m`; a tenth of g, well inside what a tilt-limited UAV with its share of the load does).
pub const STOP_DECEL_MPS2: f32 = 1.0;
/// Kept between a stopped UAV's body and what blocks its tube, m (the map's cells, the
/// LiDAR's noise and the hand-over's 100 ms).
pub const STOP_MARGIN_M: f32 = 1.0;

/// How far ahead of a UAV an obstacle in its tube makes it stop, m: its body radius
/// `body_r_m`, the distance to stop from `v_max_mps` at [`STOP_DECEL_MPS2`], and
/// [`STOP_MARGIN_M`]. Non-finite or negative inputs count as 0.
pub fn stop_distance_m(body_r_m: f32, v_max_mps: f32) -> f32 {
    let ok = |x: f32| if x.is_finite() && x > 0.0 { x } else { 0.0 };
    let v = ok(v_max_mps);
    ok(body_r_m) + v * v / (2.0 * STOP_DECEL_MPS2) + STOP_MARGIN_M
}

/// The onboard map's configuration (from the `PR_*` parameters).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerceptionConfig {
    /// World bounds `[x_min, x_max, y_min, y_max]`, ENU, m.
    pub bounds_m: [f32; 4],
    /// Map cell side, m.
    pub cell_m: f32,
    /// The mission's goal, ENU, m.
    pub goal_m: [f32; 2],
    /// Scheduled re-plan period, ms.
    pub replan_period_ms: u32,
    /// The planner's parameters (half-width the team needs, margin, caps).
    pub plan: PlanParams,
}

impl PerceptionConfig {
    /// The configuration the `PR_*` parameters give (`None`: `PR_MAP` 0, the tube is given).
    pub fn from_params(p: &crate::params::Params) -> Option<Self> {
        use crate::params::Param;
        (p.get_u32(Param::PrMap) == 1).then(|| Self {
            bounds_m: [p.get(Param::PrX0), p.get(Param::PrX1), p.get(Param::PrY0), p.get(Param::PrY1)],
            cell_m: p.get(Param::PrCell),
            goal_m: [p.get(Param::PrGoalX), p.get(Param::PrGoalY)],
            replan_period_ms: p.get_u32(Param::PrPeriod),
            plan: PlanParams {
                need_half_width_m: p.get(Param::PrHalfW),
                margin_m: p.get(Param::PrMargin),
                max_half_width_m: p.get(Param::PrMaxHw),
                lattice_m: p.get(Param::PrLattice),
                clearance_weight: p.get(Param::PrKw),
            },
        })
    }

    /// The `PR_*` parameters that give this configuration ([`Self::from_params`]' inverse).
    pub fn params(&self) -> [(crate::params::Param, f32); 14] {
        use crate::params::Param;
        let [x0, x1, y0, y1] = self.bounds_m;
        let pl = &self.plan;
        [
            (Param::PrMap, 1.0),
            (Param::PrX0, x0),
            (Param::PrX1, x1),
            (Param::PrY0, y0),
            (Param::PrY1, y1),
            (Param::PrCell, self.cell_m),
            (Param::PrGoalX, self.goal_m[0]),
            (Param::PrGoalY, self.goal_m[1]),
            (Param::PrPeriod, self.replan_period_ms as f32),
            (Param::PrHalfW, pl.need_half_width_m),
            (Param::PrMargin, pl.margin_m),
            (Param::PrMaxHw, pl.max_half_width_m),
            (Param::PrLattice, pl.lattice_m),
            (Param::PrKw, pl.clearance_weight),
        ]
    }
}

/// Why a companion kept its tube.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Keep {
    /// The new tube does not contain this UAV with its margin.
    OwnOutside,
    /// The new tube does not contain the load with its margin.
    LoadOutside,
    /// The new tube would bring the barrier closer than the old one did.
    BarrierJump,
}

/// The planner's work space (about 43 KiB): the map's occupied cells in bits (a copy, so the
/// map keeps taking scans while the planner reads it) and the lattice search's arrays (a radius
/// byte, a key, two `u16` and a parent step in half a byte a node; `vt_plan::Workspace::keys_only`). Apart from the map, so a
/// board can lend it to a task of lower priority ([`Perception::prepare`], [`PlannerSpace::plan`]).
pub struct PlannerSpace {
    plan_bits: [u32; PLAN_WORDS],
    /// The lattice's disc radii, a byte a node (`vt_plan::RadiusCell` for `u8`).
    radii: [u8; LATTICE_NODES],
    /// The lattice's keys, an `f32` a node (a node's cost is its key less the heuristic).
    keys: [f32; LATTICE_NODES],
    /// The lattice's two `u16` a node.
    ints: [u16; 2 * LATTICE_NODES],
    /// The search's parents, a step in half a byte a node.
    steps: [u8; Workspace::<u16>::parent_bytes(LATTICE_NODES)],
}

impl PlannerSpace {
    /// Storage, every byte zero (`.bss` in a firmware's `static`).
    pub const fn zeroed() -> Self {
        Self {
            plan_bits: [0; PLAN_WORDS],
            radii: [0; LATTICE_NODES],
            keys: [0.0; LATTICE_NODES],
            ints: [0; 2 * LATTICE_NODES],
            steps: [0; Workspace::<u16>::parent_bytes(LATTICE_NODES)],
        }
    }

    /// The search of a re-plan [`Perception::prepare`]d into this space: the planner
    /// (`vt_plan::plan_in`) on the map's bits, on this space alone. The expensive part of a
    /// re-plan (docs/benchmarks.md).
    ///
    /// `check` is the planner's tube storage: on success it holds the planned tube, built from
    /// its waypoints on the mission protocol's grid (what a member builds from the offer).
    ///
    /// # Errors
    /// The planner's: no route, a start inside an obstacle.
    pub fn plan(&mut self, p: &Prepared, check: &mut CompanionTube) -> Result<PlannedTube, PlanError> {
        let bits = OccupancyBits(&self.plan_bits);
        let grid = OccupancyMap { bits, width: p.width, height: p.height, resolution_m: p.resolution_m, origin_m: p.origin_m };
        let mut ws = Workspace::keys_only(&mut self.radii, &mut self.keys, &mut self.ints, &mut self.steps);
        vt_plan::plan_in(&grid, p.start_m, p.goal_m, &p.params, &mut ws, check, crate::mission::on_wire_grid_m)
    }
}

/// A re-plan made ready in a [`PlannerSpace`] ([`Perception::prepare`]): the map's cells copied
/// in, where it starts and ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prepared {
    width: usize,
    height: usize,
    resolution_m: f32,
    origin_m: vt_plan::Vec2,
    start_m: vt_plan::Vec2,
    goal_m: vt_plan::Vec2,
    params: PlanParams,
}

/// The onboard map and the trigger.
pub struct Perception {
    cfg: PerceptionConfig,
    map: OnboardMap,
    blocked: bool,
    /// Arc length along the tube of the nearest obstacle cell seen in it ahead of the load, m.
    blocked_s_m: f32,
    /// Arc length along the tube of the farthest such cell, m (`-inf`: none).
    blocked_end_s_m: f32,
    next_plan_ms: u32,
    last_plan_ms: Option<u32>,
    replans: u32,
    /// How far behind the load the last re-plan started, m.
    backoff_m: f32,
}

impl Perception {
    /// An empty map of `cfg`'s world.
    ///
    /// # Errors
    /// As [`Perception::configure`].
    pub fn new(cfg: PerceptionConfig) -> Result<Self, vt_map::MapError> {
        let mut p = Self::placeholder();
        p.configure(cfg)?;
        Ok(p)
    }

    /// Storage for the perception state before it is configured: a map of no cells, every scan
    /// ignored, every re-plan an error. `const` and every byte zero, so firmware keeps it in a
    /// `static` in `.bss`, with no image in flash (about 17 KiB: built on the stack and moved,
    /// as [`Perception::new`]'s result is, it would need that much stack; a single non-zero
    /// word would put all of it in `.data`, in flash), and [`Perception::configure`] gives it
    /// its world and figures in place.
    pub const fn placeholder() -> Self {
        Self {
            cfg: PerceptionConfig {
                bounds_m: [0.0; 4],
                cell_m: 0.0,
                goal_m: [0.0; 2],
                replan_period_ms: 0,
                plan: PlanParams { need_half_width_m: 0.0, margin_m: 0.0, max_half_width_m: 0.0, lattice_m: 0.0, clearance_weight: 0.0 },
            },
            map: OnboardMap::zeroed(),
            blocked: false,
            blocked_s_m: 0.0,
            blocked_end_s_m: 0.0,
            next_plan_ms: 0,
            last_plan_ms: None,
            replans: 0,
            backoff_m: 0.0,
        }
    }

    /// Configures this storage in place for `cfg`'s world: an empty map, no re-plan yet. On
    /// error nothing changes.
    ///
    /// # Errors
    /// The world does not fit [`MAP_CELLS`] at `cfg.cell_m`, or the figures are not finite.
    pub fn configure(&mut self, cfg: PerceptionConfig) -> Result<(), vt_map::MapError> {
        let [x0, x1, y0, y1] = cfg.bounds_m;
        let w = libm::ceilf((x1 - x0) / cfg.cell_m);
        let h = libm::ceilf((y1 - y0) / cfg.cell_m);
        if !(w >= 1.0 && h >= 1.0 && w * h <= MAP_CELLS as f32) {
            return Err(vt_map::MapError::TooManyCells { needed: if w * h >= 0.0 { (w * h) as usize } else { 0 }, capacity: MAP_CELLS });
        }
        self.map.adopt(&LOG_ODDS)?;
        self.map.reset(w as usize, h as usize, cfg.cell_m, vt_map::Vec2::new(x0, y0))?;
        self.cfg = cfg;
        self.blocked = false;
        self.blocked_s_m = f32::INFINITY;
        self.blocked_end_s_m = f32::NEG_INFINITY;
        self.next_plan_ms = 0;
        self.last_plan_ms = None;
        self.replans = 0;
        self.backoff_m = BACKOFF_M;
        Ok(())
    }

    /// Fuses one scan (own or relayed). With the current `tube` and the load's arc length
    /// `load_s_m` along it, a newly occupied cell whose square reaches into the tube ahead of
    /// the team's back-off point raises [`Self::blocked`] (the planner keeps its margin outside
    /// the tube: cells flickering there do not block it).
    ///
    /// A beam is a sector, as `OBSTACLE_DISTANCE` defines it: the *closest* obstacle within
    /// the sector's angle is at the reported range. So the whole sector is free up to that
    /// range and the obstacle lies somewhere on its arc there: the map frees the circular
    /// sector and marks the arc within [`SPREAD_RANGE_M`], its centre beyond
    /// ([`vt_map::OccupancyGrid::integrate_sectors`]; a single centre ray would leave gaps of
    /// `range x increment`, 1.3 m at 15 m and 5 deg, that a tube could cut through).
    pub fn integrate(&mut self, scan: &Scan, tube: Option<&CompanionTube>, load_s_m: f32) {
        // A cell's square reaches into the tube when its centre is within half a diagonal.
        let margin = 0.71 * self.cfg.cell_m;
        let mut blocked = false;
        let (mut blocked_s, mut blocked_end_s) = (self.blocked_s_m, self.blocked_end_s_m);
        let map = &mut self.map;
        let (res, origin) = (map.resolution_m(), map.origin_m());
        // The tube lookups of one scan's new cells warm-start from the previous one's section.
        let mut hint = 0usize;
        map.integrate_sectors(scan, &LOG_ODDS, FOLD, |i, j| {
            let Some(tube) = tube else {
                return;
            };
            let c = origin + vt_map::Vec2::new((i as f32 + 0.5) * res, (j as f32 + 0.5) * res);
            if let Some(sec) = tube.locate(c, hint) {
                hint = sec.segment;
                if sec.boundary_distance_m(c) > -margin && sec.s_m > load_s_m {
                    blocked = true;
                    blocked_s = blocked_s.min(sec.s_m);
                    blocked_end_s = blocked_end_s.max(sec.s_m);
                }
            }
        });
        self.blocked |= blocked;
        self.blocked_s_m = blocked_s;
        self.blocked_end_s_m = blocked_end_s;
    }

    /// How far ahead of the load (arc length `load_s_m` on the current tube) the nearest
    /// obstacle seen in that tube lies, m (infinite: none seen since the last re-plan).
    pub fn blocked_ahead_m(&self, load_s_m: f32) -> f32 {
        self.blocked_s_m - load_s_m
    }

    /// The companion must stop: obstacle cells its map has seen in its own tube span arc
    /// lengths `[s0, s1]`, the UAV's own section `own_s_m` lies before `s1`, and `s0` is less
    /// than `stop_m` ([`stop_distance_m`]) ahead of it; and it has not switched to a tube since
    /// (a switch clears it, [`Self::handed_over`]). Flying on would take it into what the map
    /// has seen; holding in place does not. A UAV past the nearest cell but not the farthest is
    /// still stopped: the rest of the obstacle lies ahead of it. An obstacle wholly behind the
    /// UAV's section does not stop it. The decision of docs/design.md, "Stopping before a seen
    /// obstacle".
    pub fn must_stop(&self, own_s_m: f32, stop_m: f32) -> bool {
        own_s_m <= self.blocked_end_s_m && self.blocked_ahead_m(own_s_m) < stop_m
    }

    /// A newly seen obstacle lies in the tube ahead: re-plan now.
    pub fn blocked(&self) -> bool {
        self.blocked
    }

    /// A re-plan is due at `now_ms` (scheduled, or [`Self::blocked`]).
    pub fn replan_due(&self, now_ms: u32) -> bool {
        let gap_ok = self.last_plan_ms.is_none_or(|t| now_ms.wrapping_sub(t) >= MIN_REPLAN_GAP_MS);
        (self.blocked && gap_ok) || now_ms >= self.next_plan_ms
    }

    /// Re-plans from the team's current section of `tube` (the load at `load_m`) to the goal
    /// on the map as seen so far. The schedule restarts and the trigger clears whatever the
    /// outcome (a failed plan is retried on schedule). The planned tube is built in `check`
    /// ([`PlannerSpace::plan`]).
    ///
    /// # Errors
    /// The planner's: no route (the team holds), a start inside an obstacle.
    pub fn replan(&mut self, tube: &CompanionTube, load_m: &Vec3, now_ms: u32, space: &mut PlannerSpace, check: &mut CompanionTube) -> Result<PlannedTube, PlanError> {
        self.replan_from(tube, load_m, BACKOFF_M, now_ms, space, check)
    }

    /// [`Self::replan`] from `backoff_m` behind the load along `tube` (0: from the load's
    /// section).
    ///
    /// # Errors
    /// As [`Self::replan`].
    pub fn replan_from(&mut self, tube: &CompanionTube, load_m: &Vec3, backoff_m: f32, now_ms: u32, space: &mut PlannerSpace, check: &mut CompanionTube) -> Result<PlannedTube, PlanError> {
        let p = self.prepare(tube, load_m, backoff_m, 0.0, now_ms, space)?;
        space.plan(&p, check)
    }

    /// The first part of [`Self::replan_from`], on the map: the schedule restarts and the
    /// trigger clears, the start is placed `backoff_m` behind the load along `tube`, the
    /// planner asks for the half-width the flown formation needs (`need_m`, m;
    /// [`Self::plan_params`]), and the map's cells are copied into `space`;
    /// [`PlannerSpace::plan`] does the rest, on `space` alone.
    ///
    /// # Errors
    /// The map does not fit the planner's grid.
    pub fn prepare(&mut self, tube: &CompanionTube, load_m: &Vec3, backoff_m: f32, need_m: f32, now_ms: u32, space: &mut PlannerSpace) -> Result<Prepared, PlanError> {
        self.blocked = false;
        self.backoff_m = backoff_m;
        self.last_plan_ms = Some(now_ms);
        self.next_plan_ms = now_ms.saturating_add(self.cfg.replan_period_ms);
        self.replans = self.replans.saturating_add(1);
        let start_m = start_point_at(tube, load_m, backoff_m);
        let (width, height) = self.map.write_planner_bits(&mut space.plan_bits).map_err(|_| PlanError::BadParams { field: "plan cells" })?;
        Ok(Prepared {
            width,
            height,
            resolution_m: self.map.resolution_m(),
            origin_m: self.map.origin_m(),
            start_m,
            goal_m: vt_plan::Vec2::new(self.cfg.goal_m[0], self.cfg.goal_m[1]),
            params: self.plan_params(need_m),
        })
    }

    /// The planner's parameters for a formation that needs `need_m` of half-width (m; the
    /// configured `PR_HALF_W` when it asks for less, or for a non-finite figure): at most the
    /// configured widest half-width, which the planner requires to hold the need.
    pub fn plan_params(&self, need_m: f32) -> PlanParams {
        let mut p = self.cfg.plan;
        if need_m.is_finite() && need_m > p.need_half_width_m {
            p.need_half_width_m = vt_fpu::min(need_m, p.max_half_width_m);
        }
        p
    }

    /// Whether the team should switch from `current` to the tube of waypoints `planned` (the
    /// load at `load_m`): an
    /// obstacle was seen in `current` since the last switch, or `planned` is
    /// [`SHORTER_TO_SWITCH`] shorter than what remains of `current`.
    pub fn worth_switching(&self, current: &CompanionTube, planned: &[Waypoint], load_m: &Vec3) -> bool {
        let remaining = current.locate(load_m.xy(), 0).map_or(f32::INFINITY, |sec| sec.remaining_m);
        let len: f32 = planned.windows(2).map(|w| match w {
            [a, b] => (b.pos_m - a.pos_m).norm(),
            _ => 0.0,
        }).sum::<f32>() - self.backoff_m;
        self.blocked_s_m.is_finite() || len < (1.0 - SHORTER_TO_SWITCH) * remaining
    }

    /// The planned tube went to the team: what blocks a tube is measured along the new one
    /// from now on.
    pub fn handed_over(&mut self) {
        self.blocked_s_m = f32::INFINITY;
        self.blocked_end_s_m = f32::NEG_INFINITY;
    }

    /// Re-plans started so far.
    pub fn replans(&self) -> u32 {
        self.replans
    }

    /// The map.
    pub fn map(&self) -> &OnboardMap {
        &self.map
    }

    /// The configuration.
    pub fn config(&self) -> &PerceptionConfig {
        &self.cfg
    }
}

/// How the companion folds a scan: arcs marked within [`SPREAD_RANGE_M`], free space out to
/// [`FREE_RANGE_M`].
pub const FOLD: SectorFold = SectorFold { spread_range_m: SPREAD_RANGE_M, free_range_m: FREE_RANGE_M };

/// Beams are inserted out to this range, m (OctoMap's `maxrange`): the simulated LiDAR's 15 m,
/// so nothing is cut. A scan's cost on the flight MCU grows with the square of this range: at
/// 10 m the fold meets the 1 ms budget (165 k instructions against 168 k), at 15 m it takes
/// 243 k. Measured (docs/design.md, "Tubes generated in flight"): at 10 m stale cells marked
/// from afar stay out of the free space's reach, and the 3-UAV re-route flew to the goal in
/// 1 of 3 seeds (false `no_route` in 2), the yard in 0 of 3; at 15 m in 3 of 3 and 1 of 3.
/// A map that flies comes first; the budget is reported missed (docs/benchmarks.md).
pub const FREE_RANGE_M: f32 = 15.0;

/// A sector's miss, 1/16 nat (p_miss 0.29; OctoMap's ray miss is -7, p 0.4): a cell in a
/// sector's free space was crossed by every ray of the sector that passed it (the LiDAR fills a
/// 5 deg sector from ten rays 0.5 deg apart, and a 0.25 m cell at 6 m lies across two or three
/// of them), where the fold updates it once. Measured on the four unknown-map scenarios
/// (docs/design.md, "Tubes generated in flight"): with -7 the paper world's team stalled at its
/// third passage and the yard's did not arrive; -10 gave the yard a false `no_route`.
pub const SECTOR_MISS: i8 = -14;

/// Hits farther than this mark only their sector's centre, not its whole arc (the free space
/// before them is the whole sector either way): at 6 m a 5 deg arc is 0.52 m, two cells;
/// beyond, the arc would paint obstacles a metre wider than they are, closing passages the
/// team sees open once it is nearer.
pub const SPREAD_RANGE_M: f32 = 6.0;

/// Where a re-planned tube starts: the current tube's generator [`BACKOFF_M`] behind the
/// load's section (its start when the load is nearer to it).
pub fn start_point(tube: &CompanionTube, load_m: &Vec3) -> vt_plan::Vec2 {
    start_point_at(tube, load_m, BACKOFF_M)
}

/// [`start_point`] `backoff_m` behind the load's section.
pub fn start_point_at(tube: &CompanionTube, load_m: &Vec3, backoff_m: f32) -> vt_plan::Vec2 {
    let s = tube.locate(load_m.xy(), 0).map_or(0.0, |sec| sec.s_m);
    let k = libm::floorf((s - backoff_m).max(0.0) / tube.ds_m().max(f32::MIN_POSITIVE)) as usize;
    let samples = tube.samples();
    samples.get(k.min(samples.len().saturating_sub(1))).map_or(load_m.xy(), |p| p.pos_m)
}

/// Whether every position of `team` (m, the planner's view of its members) lies inside `tube`
/// by `margin_m`: a tube the whole team can take without joining it from outside.
pub fn holds_team(tube: &CompanionTube, team: impl IntoIterator<Item = vt_tube::Vec2>, margin_m: f32) -> bool {
    let mut hint = 0usize;
    team.into_iter().all(|p| {
        tube.locate(p, hint).is_some_and(|sec| {
            hint = sec.segment;
            sec.boundary_distance_m(p) >= margin_m
        })
    })
}

/// Whether the planner hands a planned tube to the team now (docs/design.md, "Handing a tube
/// over"): it is `worth` switching to, and it holds the whole team (`holds_team`). A tube
/// that leaves a member outside is never handed over, however close the block ahead: the
/// member would be outside the team's tube at once, as the switch forbids. The team
/// flies on (or stops before the block, [`Perception::must_stop`]) and the next plan, from
/// where it is then, is offered instead.
pub fn hand_over_now(worth: bool, holds_team: bool) -> bool {
    worth && holds_team
}

/// The lowest id among `healthy` members (`healthy(j)`: fresh own data, or in the view):
/// the team's planner (`None`: no one is healthy).
pub fn designated_planner(n: usize, healthy: impl Fn(usize) -> bool) -> Option<usize> {
    (0..n).find(|&j| healthy(j))
}

/// Whether a companion at `own_m`, with the load at `load_m`, may switch from `old` to `new`
/// (module docs): both inside `new` by `margin_m`, and the own barrier distance on `new` at
/// least `min(d_old, band_m)`.
///
/// # Errors
/// Why the old tube is kept.
pub fn accept(new: &CompanionTube, old: Option<&CompanionTube>, own_m: &Vec3, load_m: &Vec3, margin_m: f32, band_m: f32) -> Result<(), Keep> {
    let d = |t: &CompanionTube, p: &Vec3| t.locate(p.xy(), 0).map_or(f32::NEG_INFINITY, |sec| sec.boundary_distance_m(p.xy()));
    let d_new = d(new, own_m);
    if !(d_new >= margin_m) {
        return Err(Keep::OwnOutside);
    }
    if !(d(new, load_m) >= margin_m) {
        return Err(Keep::LoadOutside);
    }
    if let Some(old) = old {
        let d_old = d(old, own_m);
        if d_new < d_old.min(band_m) {
            return Err(Keep::BarrierJump);
        }
    }
    Ok(())
}

/// The accept rule for a UAV that can join a tube it is not inside (the dissipative
/// controller's `join_tube`): the load must lie inside `new` by `margin_m` (else
/// [`Keep::LoadOutside`]); then `Ok(false)` when [`accept`] takes `new` as it is, `Ok(true)`
/// when the own centre is outside it or the barrier would rise (the UAV joins it widened).
///
/// # Errors
/// [`Keep::LoadOutside`].
pub fn accept_joining(new: &CompanionTube, old: Option<&CompanionTube>, own_m: &Vec3, load_m: &Vec3, margin_m: f32, band_m: f32) -> Result<bool, Keep> {
    let inside = new.locate(load_m.xy(), 0).is_some_and(|sec| sec.boundary_distance_m(load_m.xy()) >= margin_m);
    if !inside {
        return Err(Keep::LoadOutside);
    }
    match accept(new, old, own_m, load_m, margin_m, band_m) {
        Ok(()) => Ok(false),
        Err(Keep::LoadOutside) => Err(Keep::LoadOutside),
        Err(Keep::OwnOutside | Keep::BarrierJump) => Ok(true),
    }
}

#[cfg(test)]
#[path = "perception_tests.rs"]
pub(crate) mod tests;
