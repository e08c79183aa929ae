//! Issue 28 in the SIL team: the team network around the companions' own re-planning
//! (`vt_companion::replanning`, attached to each `Companion` and run by it, as on the wire:
//! docs/protocol.md, "Tubes re-planned in flight"). Each companion gets the scans its UAV takes
//! and those its link relays (`Companion::scan`, as an `OBSTACLE_DISTANCE` would), and the
//! planner's offer (`Companion::offer`, as a pushed mission would); every decision (who plans,
//! when, which tube a companion takes) is the companion's (docs/design.md, "Tubes generated in
//! flight").
//!
//! Timing, as aboard: a re-plan's tube reaches the team [`PLAN_LATENCY_MS`] after the re-plan
//! (the MCU budget for a full re-plan, issue 28), and every companion then decides for itself
//! whether it switches.

use super::Tick;
use crate::companion::HostCompanion;
use crate::plan::params_of;
use crate::scenario::{LoadedScenario, MapKnowledge, Scenario, SimTube};
use vt_companion::perception::PerceptionConfig;
use vt_companion::Source;
use vt_tube::Waypoint;

/// From a re-plan to its tube at the team, ms: the flight MCU's budget for a full re-plan
/// (100 ms at 168 MHz, issue 28), which the planner allows for (`replanning::hold_margin_m`).
pub const PLAN_LATENCY_MS: u32 = vt_companion::perception::HAND_OVER_MS;

/// The onboard map configuration a scenario gives every companion (`None`: the map is known,
/// nothing is re-planned).
pub fn perception_config(s: &Scenario) -> Option<PerceptionConfig> {
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
    /// A re-plan found no route at some time of the flight: the team held (it may have
    /// resumed since, when a later re-plan found a way through cells it had not yet seen).
    pub no_route_seen: bool,
    /// The onboard map's RAM per companion, bytes.
    pub map_ram_bytes: usize,
}

impl ReplanStats {
    /// Records whether the last re-plan found no route (and that one did, once it has).
    pub fn set_no_route(&mut self, no_route: bool) {
        self.no_route = no_route;
        self.no_route_seen |= no_route;
    }
}

/// The team network's side of issue 28 in SIL: each companion re-plans aboard
/// (`vt_companion::Companion::attach_replanning`; every decision is the companion crate's);
/// this relays what the firmware's link carries: the scans (`OBSTACLE_DISTANCE`) and the
/// planner's offers, delivered [`PLAN_LATENCY_MS`] after the re-plan (at once before the start).
pub struct TeamPerception {
    /// A planned tube on its way to the team: (delivery time, waypoints on the wire grid).
    pending: Option<(u32, Vec<Waypoint>)>,
    /// The offer delivered this period, until the companions have taken it or not.
    delivered: Option<Vec<Waypoint>>,
    /// The tube the team switched to last, with a version the world follows.
    published: Option<(u32, SimTube)>,
    stats: ReplanStats,
}

impl TeamPerception {
    /// Gives each of `uavs` its map's storage (`None` when `ls` does not re-plan); each
    /// configures it from its `PR_*` parameters (a world it cannot hold refuses the start;
    /// validation refuses it first).
    pub fn attach(ls: &LoadedScenario, uavs: &mut [HostCompanion]) -> Option<Self> {
        perception_config(&ls.scenario)?;
        for uav in uavs.iter_mut() {
            uav.provide_map();
        }
        let stats = ReplanStats { map_ram_bytes: vt_companion::perception::OnboardMap::ram_bytes(), ..ReplanStats::default() };
        Some(Self { pending: None, delivered: None, published: None, stats })
    }

    /// The start of a period: the offer whose time has come is delivered in it.
    pub fn open(&mut self, tick: &Tick<'_>) {
        if tick.high_level && self.pending.as_ref().is_some_and(|(at, _)| tick.time_ms >= *at) {
            self.delivered = self.pending.take().map(|(_, w)| w);
        }
    }

    /// What reaches companion `i` this period, before its own state: the scans the team's
    /// LiDARs took (its own, and those its link relayed: the members whose position reached it),
    /// and the offer due.
    pub fn deliver(&self, c: &mut vt_companion::Companion<'static>, i: usize, tick: &Tick<'_>) {
        if !tick.high_level {
            return;
        }
        let view = tick.views.get(i);
        for (j, scan) in tick.scans.iter().enumerate() {
            let reached = j == i || view.and_then(|v| v.get(j)).is_some_and(Option::is_some);
            if let (Some(scan), true) = (scan, reached) {
                c.scan(if j == i { Source::Own } else { Source::Member(j) }, scan);
            }
        }
        if let Some(w) = &self.delivered {
            c.offer(w);
        }
    }

    /// The end of a period: what the companions did (figures, the tube the world measures
    /// against once one took an offer) and the planner's offer to relay. `immediate`: before
    /// the start, an offer goes out with no latency.
    pub fn close(&mut self, tick: &Tick<'_>, uavs: &mut [HostCompanion], immediate: bool) {
        let mut switched = false;
        let mut offer = None;
        for c in uavs.iter_mut().filter_map(HostCompanion::get_mut) {
            let r = c.take_replan_report();
            self.stats.replans += r.replans;
            self.stats.planned += r.planned;
            self.stats.switches += r.switches;
            self.stats.kept += r.kept;
            switched |= r.switches > 0;
            if let Some(no_route) = r.no_route {
                self.stats.set_no_route(no_route);
            }
            if r.offered {
                offer = c.offer_sent().map(<[Waypoint]>::to_vec);
            }
        }
        if let Some(w) = self.delivered.take() {
            if switched {
                if let Ok(t) = SimTube::from_waypoints(&w) {
                    let version = self.published.as_ref().map_or(1, |(v, _)| v + 1);
                    self.published = Some((version, t));
                }
            }
        }
        if let Some(w) = offer {
            let latency = if immediate { 0 } else { PLAN_LATENCY_MS };
            self.pending = Some((tick.time_ms.saturating_add(latency), w));
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
