//! Issue 28 over the wire: what the team network carries for in-flight re-planning between
//! companions behind ports (docs/protocol.md, "Tubes re-planned in flight"), the
//! [`crate::mission::replan::TeamPerception`] of the MAVLink backends.
//!
//! - **Scans.** Each UAV's LiDAR scan goes to its companion as `OBSTACLE_DISTANCE` from its own
//!   autopilot (component 1: the autopilot's collision-prevention feed), and to every member
//!   its position reached this period from the scanning UAV's system (the network relays it).
//! - **Offers.** A planner's push (`MISSION_COUNT` + `MISSION_ITEM_INT`, broadcast) is taken
//!   off its reply and relayed to every companion, its sender's too, from the sender's
//!   companion (component 191), [`PLAN_LATENCY_MS`] later (at once before the start): the
//!   SIL team's timing.
//! - **Figures.** The counts each companion reports (`DEBUG_VECT` `REPLAN`, `TUBES`) and its
//!   no-route `STATUSTEXT`: the same [`ReplanStats`] as SIL's. The world measures against an
//!   offer once a companion switched to it in the period it was delivered.
//!
//! The relay makes no decision: every one is the companion's.

use super::wire::{Encoder, Rx};
use super::{err, PilError, AUTOPILOT_COMPONENT_ID, SYSID_BASE};
use crate::mission::replan::{perception_config, ReplanStats, PLAN_LATENCY_MS};
use crate::mission::Tick;
use crate::scenario::{LoadedScenario, SimTube};
use mavlink::dialects::common::{MISSION_COUNT_DATA, MISSION_ITEM_INT_DATA};
use vt_companion::companion::NO_ROUTE_TEXT;
use vt_companion::mission::{Item, MissionUpload, UploadReply};
use vt_companion::COMPANION_COMPONENT_ID;

/// An offer taken off a planner's reply: its sender's index, and its items in order.
#[derive(Debug, Clone)]
struct Offer {
    from: usize,
    items: Vec<MISSION_ITEM_INT_DATA>,
}

/// The team network's side of issue 28 for companions behind ports.
#[derive(Debug)]
pub struct PortPerception {
    /// The LiDAR's sector width on the wire, whole degrees.
    increment_deg: u8,
    /// Per UAV, an offer being read off its reply: (count announced, items so far).
    incoming: Vec<Option<(u16, Vec<MISSION_ITEM_INT_DATA>)>>,
    /// The offer read off this period's replies (the last sender's).
    offered: Option<Offer>,
    /// An offer on its way to the team: (delivery time, ms; the offer).
    pending: Option<(u32, Offer)>,
    /// The offer delivered this period.
    delivered: Option<Offer>,
    /// Per UAV, the last `REPLAN` and `TUBES` it reported.
    totals: Vec<([f32; 3], [f32; 3])>,
    /// The switches summed over the team at the last period's end.
    switches_before: f32,
    published: Option<(u32, SimTube)>,
    stats: ReplanStats,
}

impl PortPerception {
    /// The relay for `n` companions flying `ls` (`None`: the map is known).
    ///
    /// # Errors
    /// The scenario's LiDAR takes scans `OBSTACLE_DISTANCE` cannot carry (a full turn of
    /// whole-degree sectors that divide 90).
    pub fn new(ls: &LoadedScenario, n: usize) -> Result<Option<Self>, PilError> {
        if perception_config(&ls.scenario).is_none() {
            return Ok(None);
        }
        let Some(increment_deg) = ls.scenario.sensors.lidar.as_ref().and_then(wire_increment_deg) else {
            return err(format!(
                "{}: `[sensors.lidar]` must scan a full turn (fov_deg = 360) in whole-degree sectors that divide 90 (beams = 360 / 5, 6, 9, 10, 15, 18, 30, 45 or 90) for `OBSTACLE_DISTANCE` to carry its scans",
                ls.source_name
            ));
        };
        let stats = ReplanStats { map_ram_bytes: vt_companion::perception::OnboardMap::ram_bytes(), ..ReplanStats::default() };
        Ok(Some(Self {
            increment_deg,
            incoming: vec![None; n],
            offered: None,
            pending: None,
            delivered: None,
            totals: vec![([0.0; 3], [0.0; 3]); n],
            switches_before: 0.0,
            published: None,
            stats,
        }))
    }

    /// The start of a period: the offer whose time has come is delivered in it.
    pub fn open(&mut self, tick: &Tick<'_>) {
        if tick.high_level && self.pending.as_ref().is_some_and(|(at, _)| tick.time_ms >= *at) {
            self.delivered = self.pending.take().map(|(_, o)| o);
        }
    }

    /// The frames the network relays to companion `i` (system `system_id`) this period,
    /// before its own state: the scans of the UAVs whose position reached it (its own from
    /// its autopilot, through `autopilot`), in UAV order, then the offer due. As SIL's
    /// `TeamPerception::deliver`.
    pub fn frames_for(&self, i: usize, system_id: u8, tick: &Tick<'_>, autopilot: &mut Encoder, network: &mut Encoder) -> Vec<u8> {
        let mut out = Vec::new();
        if !tick.high_level {
            return out;
        }
        let view = tick.views.get(i);
        let time_usec = u64::from(tick.time_ms) * 1000;
        for (j, scan) in tick.scans.iter().enumerate() {
            let reached = j == i || view.and_then(|v| v.get(j)).is_some_and(Option::is_some);
            let Some(msg) = scan.as_ref().filter(|_| reached).and_then(|s| vt_companion::scans::encode(s, self.increment_deg, time_usec)) else {
                continue;
            };
            if j == i {
                out.extend(autopilot.frame(system_id, AUTOPILOT_COMPONENT_ID, &msg));
            } else {
                out.extend(network.frame(member_system(j), AUTOPILOT_COMPONENT_ID, &msg));
            }
        }
        if let Some(o) = &self.delivered {
            let sys = member_system(o.from);
            let count = u16::try_from(o.items.len()).unwrap_or(u16::MAX);
            out.extend(network.frame(sys, COMPANION_COMPONENT_ID, &MISSION_COUNT_DATA { count, target_system: 0, target_component: 0 }));
            for it in &o.items {
                out.extend(network.frame(sys, COMPANION_COMPONENT_ID, it));
            }
        }
        out
    }

    /// What companion `i` sent: an offer's frames, its counts, a no-route `STATUSTEXT`.
    pub fn absorb(&mut self, i: usize, rx: &Rx) {
        match rx {
            Rx::MissionCount(count) => {
                if let Some(slot) = self.incoming.get_mut(i) {
                    *slot = Some((*count, Vec::new()));
                }
            }
            Rx::MissionItem(it) => {
                let Some(slot) = self.incoming.get_mut(i) else {
                    return;
                };
                if let Some((count, items)) = slot {
                    items.push((**it).clone());
                    if items.len() == usize::from(*count) {
                        self.offered = Some(Offer { from: i, items: std::mem::take(items) });
                        *slot = None;
                    }
                }
            }
            Rx::Replan(v) => {
                if let Some(t) = self.totals.get_mut(i) {
                    t.0 = *v;
                }
            }
            Rx::Tubes(v) => {
                if let Some(t) = self.totals.get_mut(i) {
                    if t.1[2] == 1.0 && v[2] == 0.0 {
                        self.stats.set_no_route(false); // a route again
                    }
                    t.1 = *v;
                }
            }
            Rx::StatusText(_, text) if text == NO_ROUTE_TEXT => self.stats.set_no_route(true),
            _ => {}
        }
    }

    /// The end of a period (`time_ms`): the figures, the tube the world measures against, and
    /// the offer to relay. `immediate`: before the start, an offer goes out with no latency.
    pub fn close(&mut self, time_ms: u32, immediate: bool) {
        let sum = |k: fn(&([f32; 3], [f32; 3])) -> f32| self.totals.iter().map(k).sum::<f32>() as u32;
        self.stats.replans = sum(|t| t.0[0]);
        self.stats.planned = sum(|t| t.0[1]);
        self.stats.switches = sum(|t| t.1[0]);
        self.stats.kept = sum(|t| t.1[1]);
        let switches = self.stats.switches as f32;
        if let Some(o) = self.delivered.take() {
            if switches > self.switches_before {
                if let Some(t) = tube_of(&o.items) {
                    let version = self.published.as_ref().map_or(1, |(v, _)| v + 1);
                    self.published = Some((version, t));
                }
            }
        }
        self.switches_before = switches;
        if let Some(o) = self.offered.take() {
            let latency = if immediate { 0 } else { PLAN_LATENCY_MS };
            self.pending = Some((time_ms.saturating_add(latency), o));
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

    /// Per UAV, its longest re-plan as it reported it (`REPLAN.z`), board cycles.
    pub fn worst_replan_cycles(&self) -> Vec<f32> {
        self.totals.iter().map(|t| t.0[2]).collect()
    }
}

/// UAV `j`'s system id.
fn member_system(j: usize) -> u8 {
    SYSID_BASE.saturating_add(u8::try_from(j).unwrap_or(u8::MAX))
}

/// The sector width of `lidar`'s scans on the wire, whole degrees (`None`: not a full turn of
/// whole-degree sectors that divide 90).
fn wire_increment_deg(lidar: &crate::lidar::LidarSpec) -> Option<u8> {
    let inc = 360.0 / lidar.beams as f64;
    (lidar.fov_deg >= 360.0 && inc.fract() == 0.0 && inc >= 1.0 && 90.0 % inc == 0.0).then_some(inc as u8)
}

/// The tube an offer's items give, read as a companion reads them (`MissionUpload`).
fn tube_of(items: &[MISSION_ITEM_INT_DATA]) -> Option<SimTube> {
    let mut up = MissionUpload::new();
    if !matches!(up.begin(u16::try_from(items.len()).ok()?), UploadReply::Request(_)) {
        return None;
    }
    for d in items {
        let it = Item { seq: d.seq, frame: d.frame as u8, command: d.command as u16, x: d.x, y: d.y, param1: d.param1, param2: d.param2 };
        up.item(&it);
    }
    SimTube::from_waypoints(up.waypoints()).ok()
}
