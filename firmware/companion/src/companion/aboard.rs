//! Issue 28 aboard (feature `perception`): the companion's side of in-flight re-planning
//! around its [`Replanning`] (docs/design.md, "Tubes generated in flight"; docs/protocol.md,
//! "Tubes re-planned in flight").
//!
//! - **Scans.** `OBSTACLE_DISTANCE` from the own system is this UAV's LiDAR, placed at the own
//!   position the companion holds; from a member's system (the team network relays it), that
//!   member's LiDAR, placed at the member's last position. Each is folded into the map on
//!   receipt.
//! - **Offers.** The planner pushes its tube to the team: `MISSION_COUNT` then every
//!   `MISSION_ITEM_INT`, broadcast (target system 0), from its companion (component 191),
//!   without the ground station's requests. A broadcast reaches its sender too, as a UDP
//!   broadcast does, so the planner takes its own offer as the others do. A complete offer
//!   waits for the next perception step; each member answers `MISSION_ACK` (accepted, or
//!   denied: it keeps its tube, and retries).
//! - **The perception step** runs before each high-level step (and, before the mission, at each
//!   own state): the watch, an offer, the planner's re-plan ([`Replanning`]'s order).
//! - **No route.** The planner holds with `HoldReasons::NO_ROUTE` and says so in a
//!   `STATUSTEXT`; the team follows through the team failsafe (its heartbeat in `Hold`).

use mavlink::dialects::common::{
    MavFrame, DEBUG_VECT_DATA, MavMissionResult, MavSeverity, MISSION_ACK_DATA, MISSION_COUNT_DATA, MISSION_ITEM_INT_DATA,
    OBSTACLE_DISTANCE_DATA, STATUSTEXT_DATA,
};

use super::{Companion, Core, Io, Source};
use crate::framer::Frame;
use crate::mission::{Item, MissionUpload, UploadReply};
use crate::params::Param;
use crate::replanning::{BuildJob, PlanJob, Planned, Replanning, Searched, TeamView};
use crate::{Vec3, COMPANION_COMPONENT_ID, MAX_UAVS};
use vt_map::Scan;
use vt_tube::Waypoint;

/// `STATUSTEXT` of a planner that found no route (the team holds).
pub const NO_ROUTE_TEXT: &str = "no route to the goal on the map as seen: holding";

/// Whether the map follows the `PR_*` parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum MapState {
    /// New storage, or a `PR_*` parameter changed: configured at the next use.
    Stale,
    /// `PR_MAP` 0: the tube is given, nothing is mapped or re-planned.
    Off,
    /// Configured from the parameters, in use.
    On,
    /// `PR_MAP` 1, but the world does not fit the map (the start is refused).
    Unfit,
}

/// The companion's re-planning and its link state.
pub(super) struct Aboard<'t> {
    replanning: Replanning<'t, 't>,
    map: MapState,
    /// An offer being received.
    incoming: MissionUpload,
    /// The system id the incoming offer comes from.
    incoming_from: u8,
    /// A complete offer waits for the next perception step.
    offer_ready: bool,
    /// What happened since the owner last looked ([`Companion::take_replan_report`]).
    report: ReplanReport,
    /// Team data (the load's or a member's state) arrived in the current period.
    team_data: bool,
    /// The counts since the map was configured, as the telemetry reports them.
    totals: ReplanTotals,
}

/// Where a companion keeps its re-planning's state (about 6 kB: the re-planning, an offer being
/// received, the counts), given with the storage ([`Companion::attach_replanning`]; a
/// firmware's `static`). Held by reference, the state is never moved: taken out of the
/// companion by value at each perception step, it was copied onto the stack and back under
/// the planner's frames (the flight's deepest stack, docs/benchmarks.md).
pub struct ReplanSlot<'t>(Option<Aboard<'t>>);

impl<'t> ReplanSlot<'t> {
    /// An empty slot (`.bss` in a firmware's `static`).
    pub const fn new() -> Self {
        Self(None)
    }

    /// The state, once attached.
    fn state(&self) -> Option<&Aboard<'t>> {
        self.0.as_ref()
    }

    /// The state, mutable, once attached.
    fn state_mut(&mut self) -> Option<&mut Aboard<'t>> {
        self.0.as_mut()
    }
}

impl Default for ReplanSlot<'_> {
    fn default() -> Self {
        Self::new()
    }
}

/// What a companion's re-planning did since its map was configured: what `DEBUG_VECT`
/// [`NAME_REPLAN`] and [`NAME_TUBES`] report after each perception step that changed it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReplanTotals {
    /// Re-plans started.
    pub replans: u32,
    /// Re-plans that gave a tube.
    pub planned: u32,
    /// Switches to an offered tube.
    pub switches: u32,
    /// Offers declined.
    pub kept: u32,
    /// This planner holds the team for want of a route.
    pub no_route: bool,
    /// The longest re-plan, board cycles (`Io::cycles`).
    pub worst_cycles: u32,
}

/// `DEBUG_VECT` name of the re-planning counts: x re-plans started, y re-plans that gave a
/// tube, z the longest re-plan in board cycles.
pub const NAME_REPLAN: &str = "REPLAN";
/// `DEBUG_VECT` name of the tube counts: x switches to an offered tube, y offers declined, z 1
/// while this planner holds the team for want of a route.
pub const NAME_TUBES: &str = "TUBES";

/// What a companion's re-planning did since it was last asked, and an offer to relay.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReplanReport {
    /// Re-plans started.
    pub replans: u32,
    /// Re-plans that gave a tube.
    pub planned: u32,
    /// Switches to an offered tube (a retry included).
    pub switches: u32,
    /// Offers declined (the tube kept).
    pub kept: u32,
    /// The last re-plan's tube went out as an offer ([`Companion::offer_sent`] holds it).
    pub offered: bool,
    /// `Some(true)`: this planner found no route and holds; `Some(false)`: a route again.
    pub no_route: Option<bool>,
}

impl<'t> Companion<'t> {
    /// Issue 28: flies with in-flight re-planning around `r` (its map and tubes), its state in
    /// `slot`; the previous one, if any, is given back with its slot.
    pub fn attach_replanning(&mut self, slot: &'t mut ReplanSlot<'t>, r: Replanning<'t, 't>) -> Option<(Replanning<'t, 't>, &'t mut ReplanSlot<'t>)> {
        let old = self.detach_replanning();
        slot.0 = Some(Aboard {
            replanning: r,
            map: MapState::Stale,
            incoming: MissionUpload::new(),
            incoming_from: 0,
            offer_ready: false,
            report: ReplanReport::default(),
            team_data: false,
            totals: ReplanTotals::default(),
        });
        self.core.aboard = Some(slot);
        old
    }

    /// Gives the re-planning's storage back, and its slot.
    pub fn detach_replanning(&mut self) -> Option<(Replanning<'t, 't>, &'t mut ReplanSlot<'t>)> {
        let slot = self.core.aboard.take()?;
        let a = slot.0.take()?;
        Some((a.replanning, slot))
    }

    /// The re-planning, if attached.
    pub fn replanning(&self) -> Option<&Replanning<'t, 't>> {
        self.core.aboard().map(|a| &a.replanning)
    }

    /// What the re-planning did since its map was configured (zero without one).
    pub fn replan_totals(&self) -> ReplanTotals {
        self.core.aboard().map(|a| a.totals).unwrap_or_default()
    }

    /// A re-plan's search for the board's task of lower priority ([`Io::plans_aside`]): run it
    /// without holding the companion ([`PlanJob::run`]), then [`Self::return_plan_job`].
    pub fn take_plan_job(&mut self) -> Option<PlanJob<'t>> {
        self.core.aboard_mut().and_then(|a| a.replanning.lend())
    }

    /// An offer's tube to build for the board's task of lower priority ([`Io::plans_aside`]):
    /// run it without holding the companion ([`BuildJob::run`]), then
    /// [`Self::return_build_job`].
    pub fn take_build_job(&mut self) -> Option<BuildJob<'t>> {
        self.core.aboard_mut().and_then(|a| a.replanning.lend_build())
    }

    /// A build back from the board's task (`built`: the tube built): the switch, or not, at the
    /// next perception step, and its `MISSION_ACK`.
    pub fn return_build_job(&mut self, job: BuildJob<'t>, built: bool) {
        if let Some(a) = self.core.aboard_mut() {
            a.replanning.give_back_build(job, built);
        }
    }

    /// A search back from the board's task, with its result and its length in board cycles:
    /// checked and offered at the next perception step.
    pub fn return_plan_job(&mut self, job: PlanJob<'t>, searched: Searched, cycles: u32) {
        if let Some(a) = self.core.aboard_mut() {
            a.replanning.give_back(job, searched);
            a.totals.worst_cycles = a.totals.worst_cycles.max(cycles);
        }
    }

    /// A range scan from `from`'s LiDAR (own, or a member's relayed by the team network): folded
    /// at that UAV's last position as this companion knows it (dropped when it knows none).
    /// What an `OBSTACLE_DISTANCE` frame does once its ids are mapped.
    pub fn scan(&mut self, from: Source, scan: &Scan) {
        self.core.fold_scan(from, scan);
    }

    /// A member's tube offer (the team network's push, already decoded): taken, or declined,
    /// at the next perception step. What a complete `MISSION_COUNT` + `MISSION_ITEM_INT` push
    /// does.
    pub fn offer(&mut self, waypoints: &[Waypoint]) {
        if !self.core.map_on() {
            return;
        }
        if let Some(a) = self.core.aboard_mut() {
            a.incoming.clear();
            let _ = a.incoming.begin(u16::try_from(waypoints.len()).unwrap_or(u16::MAX));
            for (seq, w) in (0u16..).zip(waypoints) {
                let Some(it) = Item::of_waypoint(seq, w) else {
                    a.incoming.clear();
                    return;
                };
                let _ = a.incoming.item(&it);
            }
            a.offer_ready = a.incoming.waypoints().len() == waypoints.len() && !waypoints.is_empty();
        }
    }

    /// The tube of the last offer this companion sent as the planner (its waypoints).
    pub fn offer_sent(&self) -> Option<&[Waypoint]> {
        self.core.aboard().map(|a| a.replanning.offer()).filter(|w| !w.is_empty())
    }

    /// What the re-planning did since the last call (the simulator's figures; an offer to
    /// relay when it has no frames).
    pub fn take_replan_report(&mut self) -> ReplanReport {
        self.core.aboard_mut().map(|a| core::mem::take(&mut a.report)).unwrap_or_default()
    }
}

impl<'t> Core<'t> {
    /// The re-planning's state, if attached.
    fn aboard(&self) -> Option<&Aboard<'t>> {
        self.aboard.as_deref().and_then(ReplanSlot::state)
    }

    /// The re-planning's state, mutable, if attached.
    fn aboard_mut(&mut self) -> Option<&mut Aboard<'t>> {
        self.aboard.as_deref_mut().and_then(ReplanSlot::state_mut)
    }

    /// Whether the re-planning is in use: configured from the `PR_*` parameters at the first
    /// use after they changed (an empty map, no plan). False without storage, with `PR_MAP` 0,
    /// or with a world the map cannot hold.
    pub(super) fn map_on(&mut self) -> bool {
        let Some(a) = self.aboard.as_deref_mut().and_then(ReplanSlot::state_mut) else {
            return false;
        };
        if a.map == MapState::Stale {
            a.totals = ReplanTotals::default();
            a.map = match crate::perception::PerceptionConfig::from_params(&self.params) {
                None => MapState::Off,
                Some(cfg) if a.replanning.configure(cfg).is_ok() => MapState::On,
                Some(_) => MapState::Unfit,
            };
        }
        a.map == MapState::On
    }

    /// A `PR_*` parameter changed: the map is configured afresh at its next use.
    pub(super) fn map_params_changed(&mut self) {
        if let Some(a) = self.aboard_mut() {
            a.map = MapState::Stale;
        }
    }

    /// The load's or a member's state arrived in this period.
    pub(super) fn note_team_data(&mut self) {
        if let Some(a) = self.aboard_mut() {
            a.team_data = true;
        }
    }

    /// Before the mission, in lockstep: the own state `own_m` closes a period; the perception
    /// step runs when the period brought team data (a high-level period: between them the
    /// members' positions are stale by `FS_NBR_TMO`, and every member would take itself for the
    /// planner).
    pub(super) fn preflight_period(&mut self, own_m: &Vec3, io: &mut impl Io) {
        let due = self.aboard_mut().is_some_and(|a| core::mem::take(&mut a.team_data));
        if due {
            self.perception_step(own_m, io);
        }
    }

    /// Folds `scan` at `from`'s last position (module docs).
    pub(super) fn fold_scan(&mut self, from: Source, scan: &Scan) {
        if !self.map_on() {
            return;
        }
        let origin = match from {
            Source::Own => self.sources.own.map(|s| s.value.pos_m),
            Source::Member(j) => self.sources.neighbours.get(j).copied().flatten().map(|s| s.value),
            Source::Load => None,
        };
        let Some(origin) = origin else {
            return;
        };
        let load = self.sources.load.map_or(Vec3::zeros(), |s| s.value.pos_m);
        let mut placed = scan.clone();
        placed.origin_m = origin.xy();
        // Borrowed in place, field by field: taken out, the re-planning's state (about 6 kB)
        // was copied onto the stack and back at every scan, under the map update's own frame.
        let tube = self.tube_ok.then_some(&*self.tube);
        if let Some(a) = self.aboard.as_deref_mut().and_then(ReplanSlot::state_mut) {
            a.replanning.fold(tube, &placed, &load);
        }
    }

    /// `OBSTACLE_DISTANCE`: the own LiDAR's, or a member's relayed.
    pub(super) fn on_obstacle_distance(&mut self, f: &Frame<'_>, d: &OBSTACLE_DISTANCE_DATA) {
        let Some(from) = self.team_source(f.system_id) else {
            return self.ignored();
        };
        let origin = Vec3::zeros(); // replaced by the sender's position in `fold_scan`
        match crate::scans::decode(d, &origin) {
            Some(scan) => self.fold_scan(from, &scan),
            None => self.bad_value(),
        }
    }

    /// The own system, or team member `j`'s (`VT_SYSID_BASE + j`).
    fn team_source(&self, system_id: u8) -> Option<Source> {
        if system_id == self.own_system_id() {
            return Some(Source::Own);
        }
        let j = u32::from(system_id).wrapping_sub(self.params.get_u32(Param::SysidBase)) as usize;
        (j < self.params.get_u32(Param::NUavs) as usize).then_some(Source::Member(j))
    }

    /// Whether a mission frame is a team member's offer push (its companion, any team system,
    /// this one included), not a ground station's upload.
    pub(super) fn is_offer(&mut self, f: &Frame<'_>) -> bool {
        f.component_id == COMPANION_COMPONENT_ID && self.team_source(f.system_id).is_some() && self.map_on()
    }

    /// An offer's `MISSION_COUNT`.
    pub(super) fn offer_count(&mut self, f: &Frame<'_>, d: &MISSION_COUNT_DATA) {
        if let Some(a) = self.aboard_mut() {
            a.incoming_from = f.system_id;
            a.offer_ready = false;
            if !matches!(a.incoming.begin(d.count), UploadReply::Request(_)) {
                self.bad_value();
            }
        }
    }

    /// An offer's `MISSION_ITEM_INT` (from the sender of its `MISSION_COUNT`).
    pub(super) fn offer_item(&mut self, f: &Frame<'_>, it: &Item) {
        let Some(a) = self.aboard_mut() else {
            return;
        };
        if f.system_id != a.incoming_from {
            return self.ignored();
        }
        match a.incoming.item(it) {
            UploadReply::Complete => a.offer_ready = true,
            UploadReply::Request(_) => {}
            UploadReply::Nothing => self.ignored(),
            UploadReply::Refuse(_) => self.bad_value(),
        }
    }

    /// The perception step before a high-level step (module docs), with the own position
    /// `own_m` of this period.
    pub(super) fn perception_step(&mut self, own_m: &Vec3, io: &mut impl Io) {
        if !self.map_on() {
            return;
        }
        // The slot out of the companion for the step (a reference: the state stays put).
        let Some(slot) = self.aboard.take() else {
            return;
        };
        let Some(a) = slot.state_mut() else {
            self.aboard = Some(slot);
            return;
        };
        let before = a.report;
        if a.replanning.watch(self, own_m) {
            a.report.switches += 1;
        }
        // In lockstep the searches and the offers' tubes are built in line (the flight does not
        // see their time; PIL stays SIL's bits); a board that plans aside builds them in a task
        // of lower priority, and takes an offer at the perception step after its tube came back.
        let aside = io.plans_aside() && self.params.get_u32(Param::Lockstep) != 1;
        let taken = if aside {
            let taken = a.replanning.take_built(self);
            if a.offer_ready && a.replanning.offer_aside(a.incoming.waypoints()) {
                a.offer_ready = false;
            }
            taken
        } else if core::mem::take(&mut a.offer_ready) {
            Some(a.replanning.take_offer(self, a.incoming.waypoints()))
        } else {
            None
        };
        if let Some(taken) = taken {
            match taken {
                Ok(()) => a.report.switches += 1,
                Err(_) => a.report.kept += 1,
            }
            let mavtype = if taken.is_ok() { MavMissionResult::MAV_MISSION_ACCEPTED } else { MavMissionResult::MAV_MISSION_DENIED };
            self.send(io, &MISSION_ACK_DATA { target_system: a.incoming_from, target_component: COMPANION_COMPONENT_ID, mavtype });
        }
        let now = self.clock_ms;
        let (id, n) = (self.params.get_u32(Param::Id) as usize, (self.params.get_u32(Param::NUavs) as usize).min(MAX_UAVS));
        let timeout = self.params.timeout_ms(Param::FsNbrTmo);
        let neighbours = &self.sources.neighbours;
        let fresh = |j: usize| neighbours.get(j).copied().flatten().and_then(|s| s.fresh(now, timeout));
        let healthy = |j: usize| j == id || fresh(j).is_some();
        let positions_m = (0..n).filter_map(|j| if j == id { Some(*own_m) } else { fresh(j) }).map(|p| p.xy());
        let load = self.sources.load.map_or(Vec3::zeros(), |s| s.value.pos_m);
        let t0 = io.cycles();
        let team = TeamView { id, n, healthy, positions_m };
        let planned = if aside { a.replanning.plan_aside(&*self, team, &load, now) } else { a.replanning.plan(&*self, team, &load, now) };
        if planned.replanned() && !aside {
            a.totals.worst_cycles = a.totals.worst_cycles.max(io.cycles().wrapping_sub(t0));
        }
        a.report.replans += u32::from(planned.replanned());
        a.report.planned += u32::from(planned.planned());
        match planned {
            Planned::Offer { waypoints, route_again } => {
                a.report.offered = true;
                if route_again {
                    a.report.no_route = Some(false);
                    if let Some(fl) = self.flight.as_mut() {
                        fl.set_no_route(false);
                    }
                }
                self.send_offer(waypoints, io);
            }
            Planned::NoRoute => {
                a.report.no_route = Some(true);
                if let Some(fl) = self.flight.as_mut() {
                    fl.set_no_route(true);
                }
                let mut line = crate::refusal::Line::new();
                line.push(NO_ROUTE_TEXT);
                self.send(io, &STATUSTEXT_DATA { severity: MavSeverity::MAV_SEVERITY_WARNING, text: line.bytes().into() });
            }
            Planned::Idle | Planned::Kept | Planned::Failed => {}
        }
        let r = &a.report;
        let t = &mut a.totals;
        let changed = r.replans != before.replans || r.switches != before.switches || r.kept != before.kept || r.no_route != before.no_route;
        t.replans = t.replans.wrapping_add(r.replans.wrapping_sub(before.replans));
        t.planned = t.planned.wrapping_add(r.planned.wrapping_sub(before.planned));
        t.switches = t.switches.wrapping_add(r.switches.wrapping_sub(before.switches));
        t.kept = t.kept.wrapping_add(r.kept.wrapping_sub(before.kept));
        if r.no_route != before.no_route {
            t.no_route = r.no_route == Some(true);
        }
        let totals = *t;
        self.aboard = Some(slot);
        if changed {
            self.send_replan_totals(&totals, io);
        }
    }

    /// `DEBUG_VECT` [`NAME_REPLAN`] and [`NAME_TUBES`] with `t`.
    fn send_replan_totals(&mut self, t: &ReplanTotals, io: &mut impl Io) {
        let time_usec = u64::from(self.clock_ms) * 1000;
        let f = |x: u32| x as f32;
        self.send(io, &DEBUG_VECT_DATA { time_usec, x: f(t.replans), y: f(t.planned), z: f(t.worst_cycles), name: NAME_REPLAN.into() });
        self.send(io, &DEBUG_VECT_DATA { time_usec, x: f(t.switches), y: f(t.kept), z: f(u32::from(t.no_route)), name: NAME_TUBES.into() });
    }

    /// The planner's push of `waypoints` to the team (module docs).
    fn send_offer(&mut self, waypoints: &[Waypoint], io: &mut impl Io) {
        let count = u16::try_from(waypoints.len()).unwrap_or(u16::MAX);
        self.send(io, &MISSION_COUNT_DATA { count, target_system: 0, target_component: 0 });
        for (seq, w) in (0..count).zip(waypoints) {
            let Some(it) = Item::of_waypoint(seq, w) else {
                return;
            };
            let item = MISSION_ITEM_INT_DATA {
                param1: it.param1,
                param2: it.param2,
                x: it.x,
                y: it.y,
                seq,
                command: mavlink::dialects::common::MavCmd::MAV_CMD_NAV_WAYPOINT,
                target_system: 0,
                target_component: 0,
                frame: MavFrame::MAV_FRAME_LOCAL_NED,
                ..MISSION_ITEM_INT_DATA::DEFAULT
            };
            self.send(io, &item);
        }
    }
}

#[cfg(test)]
#[path = "aboard_tests.rs"]
mod tests;
