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
use crate::companion::{HostCompanion, HostReplanning};
use crate::plan::params_of;
use crate::scenario::{LoadedScenario, MapKnowledge, SimTube};
use vt_companion::perception::PerceptionConfig;
use vt_companion::replanning::{Planned, TeamView};
use vt_tube::Waypoint;

/// From the scan that starts a re-plan to its tube at the team, ms: the flight MCU's budget
/// for a full re-plan (100 ms at 168 MHz, issue 28), which the planner allows for.
pub const PLAN_LATENCY_MS: u32 = vt_companion::perception::HAND_OVER_MS;

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

/// The team's perception: every companion's re-planning (its map, `vt_companion::replanning`)
/// and the team link's tube in transit. Every decision is the companion crate's; this is the
/// link: scans relayed, offers delivered [`PLAN_LATENCY_MS`] later, the no-route flag.
pub struct TeamPerception {
    replanning: Vec<HostReplanning>,
    /// A planned tube on its way to the team: (delivery time, waypoints on the wire grid).
    pending: Option<(u32, Vec<Waypoint>)>,
    /// The tube the team switched to last, with a version the world follows.
    published: Option<(u32, SimTube)>,
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
        let replanning = (0..n).map(|_| HostReplanning::new(cfg)).collect::<Result<Vec<_>, _>>().map_err(|e| crate::sim::SimError(format!("onboard map: {e}")))?;
        let stats = ReplanStats { map_ram_bytes: vt_map::OccupancyGrid::<{ vt_companion::perception::MAP_CELLS }>::ram_bytes(), ..ReplanStats::default() };
        Ok(Some(Self { replanning, pending: None, published: None, stats }))
    }

    /// One high-level period (`vt_companion::replanning`'s order): every companion folds the
    /// scans that reached it (its own, and the team's its link delivered) and watches its
    /// tube; a tube whose time has come reaches every companion; the designated planner
    /// re-plans when due. `immediate`: the tube goes out at once (before the start).
    pub fn step(&mut self, tick: &Tick<'_>, uavs: &mut [HostCompanion], immediate: bool) {
        if !tick.high_level {
            return;
        }
        let n = uavs.len();
        let load = tick.load.pos_m;
        for (i, (r, uav)) in self.replanning.iter_mut().zip(uavs.iter_mut()).enumerate() {
            let (Some(r), Some(c)) = (r.get_mut(), uav.get_mut()) else {
                continue;
            };
            let view = tick.views.get(i);
            for (j, scan) in tick.scans.iter().enumerate() {
                let reached = j == i || view.and_then(|v| v.get(j)).is_some_and(Option::is_some);
                if let (Some(scan), true) = (scan, reached) {
                    r.fold(c, scan, &load);
                }
            }
        }
        for ((r, uav), own) in self.replanning.iter_mut().zip(uavs.iter_mut()).zip(tick.own) {
            if let (Some(r), Some(c)) = (r.get_mut(), uav.get_mut()) {
                if r.watch(c, &own.pos_m) {
                    self.stats.switches += 1;
                }
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
            let team = tick.views.get(i).into_iter().flatten().flatten().map(|p| p.xy());
            let (Some(r), Some(c)) = (self.replanning.get_mut(i).and_then(HostReplanning::get_mut), uavs.get(i).and_then(HostCompanion::get)) else {
                continue;
            };
            let planned = r.plan(c, TeamView { id: i, n, healthy, positions_m: team }, &load, tick.time_ms);
            self.stats.replans += u32::from(planned.replanned());
            self.stats.planned += u32::from(planned.planned());
            match planned {
                Planned::Offer { waypoints, route_again } => {
                    let w = waypoints.to_vec();
                    if route_again {
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
                Planned::NoRoute => {
                    self.stats.no_route = true;
                    uavs.iter_mut().filter_map(HostCompanion::get_mut).for_each(|c| {
                        c.set_no_route(true);
                    });
                }
                Planned::Idle | Planned::Kept | Planned::Failed => {}
            }
        }
    }

    /// Delivers the offer `w` to every companion; the world measures against it once one
    /// switched.
    fn hand_over(&mut self, w: &[Waypoint], uavs: &mut [HostCompanion]) {
        let mut any = false;
        for (r, uav) in self.replanning.iter_mut().zip(uavs.iter_mut()) {
            let (Some(r), Some(c)) = (r.get_mut(), uav.get_mut()) else {
                continue;
            };
            if r.take_offer(c, w).is_ok() {
                self.stats.switches += 1;
                any = true;
            } else {
                self.stats.kept += 1;
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

