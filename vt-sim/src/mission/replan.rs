//! Issue 28 in the SIL team: every companion's onboard perception (`vt_companion::perception`)
//! fed the scans its UAV takes and those the team link relays, the designated planner's
//! re-plans, and their hand-over to the team. The decisions (who plans, when, which tube a
//! companion accepts) are the companion crate's; this is the wiring the firmware's perception
//! task and team link do aboard (docs/design.md, "Tubes generated in flight").
//!
//! Timing, as aboard: a re-plan's tube reaches the team [`PLAN_LATENCY_MS`] after the scan
//! that triggered it (the MCU budget for a full re-plan, issue 28), and every companion then
//! decides for itself whether it switches.

use super::Tick;
use crate::companion::{on_wire_grid_m, HostCompanion};
use crate::plan::params_of;
use crate::scenario::{LoadedScenario, MapKnowledge, SimTube};
use vt_companion::perception::{designated_planner, hand_over_now, holds_team, Perception, PerceptionConfig, HOLD_AHEAD_M};
use vt_plan::PlanError;
use vt_tube::Waypoint;

/// From the scan that starts a re-plan to its tube at the team, ms: the flight MCU's budget
/// for a full re-plan (100 ms at 168 MHz, issue 28).
pub const PLAN_LATENCY_MS: u32 = 100;

/// The onboard map configuration a scenario gives every companion (`None`: the map is known,
/// nothing is re-planned).
pub fn perception_config(ls: &LoadedScenario) -> Option<PerceptionConfig> {
    let s = &ls.scenario;
    let spec = s.tube.plan.as_ref()?;
    if s.perception.map != MapKnowledge::Unknown {
        return None;
    }
    let b = s.world.bounds_m;
    Some(PerceptionConfig {
        bounds_m: [b[0] as f32, b[1] as f32, b[2] as f32, b[3] as f32],
        cell_m: s.perception.cell_m as f32,
        goal_m: [spec.goal[0] as f32, spec.goal[1] as f32],
        replan_period_ms: (1000.0 / s.perception.replan_hz).round() as u32,
        plan: params_of(s, spec),
    })
}

/// What the team's perception did in one flight.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReplanStats {
    /// Re-plans started (by whichever companion was the planner).
    pub replans: u32,
    /// Re-plans that gave a tube.
    pub planned: u32,
    /// Switches to a new tube, summed over the companions.
    pub switches: u32,
    /// Offers a companion declined (it kept its tube), summed over the companions.
    pub kept: u32,
    /// The last re-plan found no route: the team holds.
    pub no_route: bool,
    /// The onboard map's RAM per companion, bytes.
    pub map_ram_bytes: usize,
}

/// The team's perception (one map per companion) and the tube in transit.
pub struct TeamPerception {
    maps: Vec<Box<Perception>>,
    /// A planned tube on its way to the team: (delivery time, waypoints on the wire grid).
    pending: Option<(u32, Vec<Waypoint>)>,
    /// The tube the planner's companion switched to last, with a version the world follows.
    published: Option<(u32, SimTube)>,
    /// The planner's copy of a planned tube, to check that it holds the team.
    check: Box<vt_companion::CompanionTube>,
    stats: ReplanStats,
}

impl TeamPerception {
    /// Empty maps for `n` companions (`None` when `ls` does not re-plan).
    ///
    /// # Errors
    /// The world does not fit the onboard map (validation refuses it first).
    pub fn new(ls: &LoadedScenario, n: usize) -> Result<Option<Self>, crate::sim::SimError> {
        let Some(cfg) = perception_config(ls) else {
            return Ok(None);
        };
        let maps = (0..n)
            .map(|_| Perception::new(cfg).map(Box::new))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| crate::sim::SimError(format!("onboard map: {e}")))?;
        let stats = ReplanStats { map_ram_bytes: vt_map::OccupancyGrid::<{ vt_companion::perception::MAP_CELLS }>::ram_bytes(), ..ReplanStats::default() };
        Ok(Some(Self { maps, pending: None, published: None, check: Box::new(vt_companion::CompanionTube::placeholder()), stats }))
    }

    /// One high-level period: fuse the scans (own, and the team's that reached each UAV),
    /// hand a tube whose time has come to every companion, and let the designated planner
    /// re-plan when due. `immediate`: the tube goes out at once (before the start).
    pub fn step(&mut self, tick: &Tick<'_>, uavs: &mut [HostCompanion], immediate: bool) {
        if !tick.high_level {
            return;
        }
        let n = uavs.len();
        for (i, (map, uav)) in self.maps.iter_mut().zip(uavs.iter()).enumerate() {
            let tube = uav.get().and_then(|c| c.tube());
            let load_s = tube.map_or(0.0, |t| load_s(t, tick));
            let view = tick.views.get(i);
            for (j, scan) in tick.scans.iter().enumerate() {
                let reached = j == i || view.and_then(|v| v.get(j)).is_some_and(Option::is_some);
                if let (Some(scan), true) = (scan, reached) {
                    map.integrate(scan, tube, load_s);
                }
            }
        }
        // A companion that declined the last tube takes it as soon as the rule allows (it keeps
        // the tube until another replaces it).
        for (uav, map) in uavs.iter_mut().zip(self.maps.iter_mut()) {
            if uav.retry_offer() {
                map.handed_over();
                self.stats.switches += 1;
            }
        }
        // A companion whose own tube is blocked close ahead of it, with no tube it may take,
        // stops (its own position as it measures it).
        for ((uav, map), own) in uavs.iter_mut().zip(self.maps.iter()).zip(tick.own) {
            let stop = uav.get().is_some_and(|c| {
                c.tube().and_then(|t| t.locate(own.pos_m.xy(), 0)).is_some_and(|sec| map.must_stop(sec.s_m, c.stop_distance_m()))
            });
            if let Some(c) = uav.get_mut() {
                c.set_blocked(stop);
            }
        }
        if let Some((at, _)) = &self.pending {
            if immediate || tick.time_ms >= *at {
                if let Some((_, w)) = self.pending.take() {
                    self.hand_over(&w, uavs);
                }
            }
        }
        for i in 0..n {
            let healthy = |j: usize| j == i || tick.views.get(i).and_then(|v| v.get(j)).is_some_and(Option::is_some);
            if designated_planner(n, healthy) != Some(i) {
                continue;
            }
            let (Some(map), Some(c)) = (self.maps.get_mut(i), uavs.get(i).and_then(HostCompanion::get)) else {
                continue;
            };
            let Some(tube) = c.tube() else {
                continue;
            };
            if !map.replan_due(tick.time_ms) {
                continue;
            }
            self.stats.replans += 1;
            let r = map.replan(tube, &tick.load.pos_m, tick.time_ms);
            match r {
                Ok(t) => {
                    self.stats.planned += 1;
                    let worth = map.worth_switching(tube, &t, &tick.load.pos_m);
                    let w: Vec<Waypoint> = t
                        .waypoints
                        .iter()
                        .map(|w| Waypoint::new(wire(w.pos_m.x), wire(w.pos_m.y), w.w_left_m, w.w_right_m))
                        .collect();
                    // Whether the planned tube holds the team as the planner sees it.
                    let team = tick.views.get(i).map(|v| v.iter().flatten().map(|p| p.xy())).into_iter().flatten();
                    let holds = worth && self.check.rebuild(&w).is_ok() && holds_team(&self.check, team, c.params().r_safe_m());
                    if !hand_over_now(worth, holds) {
                        continue;
                    }
                    if self.stats.no_route {
                        self.stats.no_route = false;
                        uavs.iter_mut().filter_map(HostCompanion::get_mut).for_each(|c| {
                            c.set_no_route(false);
                        });
                    }
                    if immediate {
                        self.hand_over(&w, uavs);
                    } else {
                        self.pending = Some((tick.time_ms.saturating_add(PLAN_LATENCY_MS), w));
                    }
                }
                Err(PlanError::TooNarrow { .. } | PlanError::InsideObstacle { .. }) if map.blocked_ahead_m(load_s(tube, tick)) < HOLD_AHEAD_M => {
                    // No route on the map as seen, and the tube is blocked close ahead: the
                    // team holds in place (vt_companion::perception's module docs).
                    self.stats.no_route = true;
                    uavs.iter_mut().filter_map(HostCompanion::get_mut).for_each(|c| {
                        c.set_no_route(true);
                    });
                }
                Err(_) => {}
            }
        }
    }

    /// Offers `w` to every companion; the world measures against the planner's new tube.
    fn hand_over(&mut self, w: &[Waypoint], uavs: &mut [HostCompanion]) {
        let mut any = false;
        for (uav, map) in uavs.iter_mut().zip(self.maps.iter_mut()) {
            match uav.offer_tube(w) {
                Ok(()) => {
                    // What blocks a tube is measured along the new one from now on; a companion
                    // that kept its tube keeps what blocks it.
                    map.handed_over();
                    self.stats.switches += 1;
                    any = true;
                }
                Err(_) => self.stats.kept += 1,
            }
        }
        if any {
            if let Ok(t) = SimTube::from_waypoints(w) {
                let version = self.published.as_ref().map_or(1, |(v, _)| v + 1);
                self.published = Some((version, t));
            }
        }
    }

    /// The tube the team switched to last, with its version (`None`: the scenario's still).
    pub fn published(&self) -> Option<(u32, &SimTube)> {
        self.published.as_ref().map(|(v, t)| (*v, t))
    }

    /// What happened so far.
    pub fn stats(&self) -> &ReplanStats {
        &self.stats
    }
}

/// The load's arc length along `tube` at `tick`, m (0 when it cannot be placed).
fn load_s(tube: &vt_companion::CompanionTube, tick: &Tick<'_>) -> f32 {
    tube.locate(tick.load.pos_m.xy(), 0).map_or(0.0, |sec| sec.s_m)
}

/// A coordinate on the mission protocol's 0.1 mm grid, as the companions rebuild it.
fn wire(v: f32) -> f32 {
    on_wire_grid_m(f64::from(v)) as f32
}
