//! Issue 28, aboard: the decisions of in-flight re-planning around one companion's map
//! ([`Perception`]): which scans it folds, when it stops before what it has seen, whether it
//! is the team's planner, when it re-plans, what it offers the team, whether it takes an offer,
//! and when the team holds for want of a route (docs/design.md, "Tubes generated in flight").
//!
//! The caller is the perception task: the firmware's, or the simulator standing in for it. It
//! brings the scans and the team link's offers, and carries [`Planned::Offer`] and the
//! no-route flag to the team. Every decision is taken here, from what this companion knows.
//!
//! One high-level period, in this order (the simulator's SIL team and the firmware's task
//! alike):
//! 1. [`Replanning::fold`] every scan that reached this UAV (its own, and those the team link
//!    relayed, each at its sender's position).
//! 2. [`Replanning::watch`]: retry a declined offer, and stop before a seen obstacle close
//!    ahead ([`Perception::must_stop`]).
//! 3. [`Replanning::take_offer`] for an offer the link delivered.
//! 4. [`Replanning::plan`]: the designated planner re-plans when due.
//!
//! A re-plan is three parts: on the map ([`Perception::prepare`]: the start, the map's cells
//! copied into the planner's work space), the search on the work space alone
//! ([`PlannerSpace::plan`], the expensive part), and the check against the team and the offer.
//! [`Replanning::plan`] runs them in a row (lockstep, SIL, a host). A board that plans aside
//! ([`Replanning::plan_aside`]) lends the work space with the prepared search to a task of
//! lower priority ([`Replanning::lend`]), which runs it ([`PlanJob::run`]) while the map keeps
//! taking scans and the control loop keeps its rate, and gives it back
//! ([`Replanning::give_back`]); the check follows at the next perception step.

use crate::perception::{designated_planner, hand_over_now, holds_team, Keep, Perception, PlannerSpace, Prepared, BACKOFF_M, HOLD_AHEAD_M};
use crate::{CompanionTube, Vec3, MAX_WAYPOINTS};
use vt_map::Scan;
use vt_plan::PlanError;
use vt_tube::Waypoint;

/// What re-planning needs of the companion it serves ([`crate::Companion`] implements it).
pub trait Crew<'t> {
    /// The tube flown (`None`: none yet).
    fn tube(&self) -> Option<&CompanionTube>;
    /// Switches to the tube in `candidate` when [`crate::perception::accept`] allows it; on
    /// success `candidate` holds the old tube's storage.
    ///
    /// # Errors
    /// Why the old tube is kept.
    fn switch_tube(&mut self, candidate: &mut &'t mut CompanionTube) -> Result<(), Keep>;
    /// How far ahead an obstacle in the tube makes this UAV stop, m.
    fn stop_distance_m(&self) -> f32;
    /// Holds this UAV in place while its own tube is blocked close ahead.
    fn set_blocked(&mut self, on: bool);
    /// The tube barrier's safety radius flown, m.
    fn r_safe_m(&self) -> f32;
    /// The team holds for want of a route.
    fn team_no_route(&self) -> bool;
    /// The velocity limit `v_m`, m/s.
    fn v_max_mps(&self) -> f32;
    /// The half-width the flown formation needs of a planned tube, m, with the load at
    /// `load_m` (`Flight::shaped_need_half_width_m`; 0: nothing beyond `PR_HALF_W`).
    fn need_half_width_m(&self, load_m: &Vec3) -> f32;
}

/// How far inside a planned tube every member must be for the plan to go over, m: the barrier's
/// safety radius `r_safe_m`, plus what a member flying at `v_max_mps` towards the new boundary
/// covers before the tube reaches it ([`crate::perception::HAND_OVER_MS`]). Non-finite or
/// negative speeds count as 0. (Its stopping distance as well was too much: docs/design.md,
/// "The hand-over's margin".)
pub fn hold_margin_m(r_safe_m: f32, v_max_mps: f32) -> f32 {
    let v = if v_max_mps.is_finite() && v_max_mps > 0.0 { v_max_mps } else { 0.0 };
    r_safe_m + v * (crate::perception::HAND_OVER_MS as f32 * 1e-3)
}

/// What one companion's re-planning keeps between periods: its map, where offers are built,
/// and the planner's check of its own plans. The storage is borrowed, as the companion's tube
/// is (about 17 KiB of map, 43 KiB of planner work space, two tubes of about 8 KiB).
pub struct Replanning<'t, 'p> {
    map: &'p mut Perception,
    /// The planner's work space (`None` while lent to a [`PlanJob`]).
    space: Option<&'p mut PlannerSpace>,
    /// A prepared search waiting to be lent ([`Self::plan_aside`]), with its back-off, m.
    ready: Option<(Prepared, f32)>,
    /// A search lent out: its back-off, m, until it comes back.
    lent: Option<f32>,
    /// A search that came back: its result and back-off, m, for the next perception step.
    done: Option<(Searched, f32)>,
    /// Where an offered tube is built before the switch; holds a declined one to retry.
    spare: Option<&'t mut CompanionTube>,
    /// An offer being built aside ([`Self::offer_aside`]): its waypoints, and the state.
    building: heapless::Vec<Waypoint, MAX_WAYPOINTS>,
    build: Build,
    /// The spare holds a tube this companion declined.
    declined: bool,
    /// The planner builds its plan here to check that it holds the team (`None` while lent
    /// with the work space).
    check: Option<&'p mut CompanionTube>,
    /// The waypoints of the last plan, on the mission protocol's grid.
    offer: heapless::Vec<Waypoint, MAX_WAYPOINTS>,
    /// This companion, as the planner, told the team there is no route.
    declared_no_route: bool,
    /// The next re-plan starts at the load's section, not [`crate::perception::BACKOFF_M`]
    /// behind it: the last one was needed but left a member outside.
    from_load: bool,
}

/// Where an offer built aside stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Build {
    /// None.
    Idle,
    /// Waiting for the task of lower priority.
    Waiting,
    /// With the task.
    Lent,
    /// Back: whether the tube built.
    Built(bool),
}

/// An offer's tube built by a task of lower priority ([`Replanning::lend_build`]): the spare
/// storage and the offer's waypoints.
pub struct BuildJob<'t> {
    spare: &'t mut CompanionTube,
    waypoints: heapless::Vec<Waypoint, MAX_WAYPOINTS>,
}

impl BuildJob<'_> {
    /// Builds the tube's tables (a few million instructions): true when it built.
    pub fn run(&mut self) -> bool {
        self.spare.rebuild(&self.waypoints).is_ok()
    }
}

/// A re-plan's search lent to a task of lower priority ([`Replanning::lend`]): the planner's
/// work space with the map's cells in it, where the search starts and ends, and the tube the
/// plan is built in for its check.
pub struct PlanJob<'p> {
    space: &'p mut PlannerSpace,
    check: &'p mut CompanionTube,
    prepared: Prepared,
}

impl PlanJob<'_> {
    /// The search and the plan's tube ([`search`]): up to tens of millions of instructions, on
    /// the job's storage alone.
    pub fn run(&mut self) -> Searched {
        search(self.space, self.check, &self.prepared)
    }
}

/// What a re-plan's search found: the plan's waypoints on the mission protocol's grid (what
/// would be offered; the plan's discs and bottleneck are not kept: 1.7 KB less in every place
/// a result waits), and whether its tube was built in the check storage.
pub struct Searched {
    result: Result<heapless::Vec<Waypoint, MAX_WAYPOINTS>, PlanError>,
    check_built: bool,
}

impl Searched {
    /// A search that could not run.
    fn failed(e: PlanError) -> Self {
        Self { result: Err(e), check_built: false }
    }

    /// Whether it found a route.
    pub fn found(&self) -> bool {
        self.result.is_ok()
    }
}

/// The expensive part of a re-plan, on its storage alone: the search ([`PlannerSpace::plan`]),
/// the plan's waypoints on the wire grid, and its tube built in `check` (the tube tables: the
/// other large cost, kept out of the control loop with the search).
pub fn search(space: &mut PlannerSpace, check: &mut CompanionTube, p: &Prepared) -> Searched {
    // The plan's waypoints are on the wire grid already, and its tube is built from them in
    // `check`: what every member builds from the offer.
    let result = space.plan(p, check).map(|t| t.waypoints);
    let check_built = result.is_ok();
    Searched { result, check_built }
}

/// What a companion knows of its team when it may plan.
#[derive(Debug, Clone, Copy)]
pub struct TeamView<H, T> {
    /// This companion's index in the team.
    pub id: usize,
    /// Team size.
    pub n: usize,
    /// `healthy(j)`: member `j`'s data is fresh (this companion always is).
    pub healthy: H,
    /// The members' last horizontal positions, m (this companion's own included).
    pub positions_m: T,
}

/// What [`Replanning::plan`] did this period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Planned<'a> {
    /// Not the planner, or no re-plan due.
    Idle,
    /// Re-planned; the plan is not handed over (not worth a switch, or it leaves a member
    /// outside).
    Kept,
    /// Re-planned: offer these waypoints (mission protocol grid) to every member, this one
    /// included. `route_again`: the team holds for want of a route and now has one: lift the
    /// no-route hold.
    Offer {
        /// The tube's waypoints.
        waypoints: &'a [Waypoint],
        /// Lift the team's no-route hold.
        route_again: bool,
    },
    /// No route on the map as seen, and the tube is blocked close ahead: the team holds in place
    /// (`HoldReasons::NO_ROUTE`).
    NoRoute,
    /// Re-planned without a route, the block (if any) still far ahead: fly on, plan again on
    /// schedule.
    Failed,
}

impl Planned<'_> {
    /// A re-plan ran this period.
    pub fn replanned(&self) -> bool {
        !matches!(self, Planned::Idle)
    }

    /// The re-plan gave a tube.
    pub fn planned(&self) -> bool {
        matches!(self, Planned::Kept | Planned::Offer { .. })
    }
}

impl<'t, 'p> Replanning<'t, 'p> {
    /// Re-planning around `map`, offers built in `spare`, plans checked in `check`.
    pub fn new(map: &'p mut Perception, space: &'p mut PlannerSpace, spare: &'t mut CompanionTube, check: &'p mut CompanionTube) -> Self {
        Self {
            map,
            space: Some(space),
            ready: None,
            lent: None,
            done: None,
            spare: Some(spare),
            building: heapless::Vec::new(),
            build: Build::Idle,
            declined: false,
            check: Some(check),
            offer: heapless::Vec::new(),
            declared_no_route: false,
            from_load: false,
        }
    }

    /// Configures the map for `cfg`'s world (empty) and forgets every plan and offer: a new
    /// mission. On error nothing changes.
    ///
    /// # Errors
    /// As [`Perception::configure`].
    pub fn configure(&mut self, cfg: crate::perception::PerceptionConfig) -> Result<(), vt_map::MapError> {
        self.map.configure(cfg)?;
        // A search or a build still out comes back to nothing (`give_back` keeps only what it
        // lent for).
        self.ready = None;
        self.lent = None;
        self.done = None;
        self.build = Build::Idle;
        self.declined = false;
        self.offer.clear();
        self.declared_no_route = false;
        self.from_load = false;
        Ok(())
    }

    /// The map.
    pub fn map(&self) -> &Perception {
        self.map
    }

    /// The waypoints of the last plan, on the mission protocol's grid (empty before one).
    pub fn offer(&self) -> &[Waypoint] {
        &self.offer
    }

    /// Gives the storage back: the map, the planner's work space (`None` while lent), the spare
    /// tube, the check tube.
    pub fn into_parts(self) -> (&'p mut Perception, Option<&'p mut PlannerSpace>, Option<&'t mut CompanionTube>, Option<&'p mut CompanionTube>) {
        (self.map, self.space, self.spare, self.check)
    }

    /// Folds one scan (own, or relayed from a member, its origin that member's position) into
    /// the map, with the companion's `tube` (`None`: none flown yet) and the load at `load_m`
    /// for the trigger ([`Perception::integrate`]).
    pub fn fold(&mut self, tube: Option<&CompanionTube>, scan: &Scan, load_m: &Vec3) {
        let load_s = tube.map_or(0.0, |t| load_s(t, load_m));
        self.map.integrate(scan, tube, load_s);
    }

    /// Retries a declined offer (true when the companion switched to it now), and stops the
    /// companion, at `own_m`, while its own tube is blocked closer ahead than it can stop
    /// ([`Perception::must_stop`], [`Crew::set_blocked`]).
    pub fn watch(&mut self, c: &mut impl Crew<'t>, own_m: &Vec3) -> bool {
        let mut switched = false;
        if let (true, Some(spare)) = (self.declined, self.spare.as_mut()) {
            switched = c.switch_tube(spare).is_ok();
            self.declined = !switched;
            if switched {
                self.map.handed_over();
            }
        }
        let stop = c.tube().and_then(|t| t.locate(own_m.xy(), 0)).is_some_and(|sec| self.map.must_stop(sec.s_m, c.stop_distance_m()));
        c.set_blocked(stop);
        switched
    }

    /// An offer the team link delivered: built in the spare storage, switched to when
    /// [`crate::perception::accept`] allows; what blocks a tube is then measured along the new
    /// one.
    ///
    /// # Errors
    /// The tube does not build (`None`), or why the companion kept its tube (it retries at
    /// every [`Self::watch`]).
    pub fn take_offer(&mut self, c: &mut impl Crew<'t>, waypoints: &[Waypoint]) -> Result<(), Option<Keep>> {
        self.declined = false;
        let built = self.spare.as_mut().is_some_and(|s| s.rebuild(waypoints).is_ok());
        self.switch_to_spare(c, built)
    }

    /// For a board that builds aside: an offer to build in the spare storage by the task of
    /// lower priority ([`Self::lend_build`]); false while another is being built (the caller
    /// keeps it for later).
    pub fn offer_aside(&mut self, waypoints: &[Waypoint]) -> bool {
        if self.build != Build::Idle || self.spare.is_none() {
            return false;
        }
        self.declined = false;
        self.building.clear();
        // Both hold MAX_WAYPOINTS.
        let _ = self.building.extend_from_slice(waypoints.get(..MAX_WAYPOINTS.min(waypoints.len())).unwrap_or(&[]));
        self.build = Build::Waiting;
        true
    }

    /// The offer's build with the spare storage, for the task of lower priority.
    pub fn lend_build(&mut self) -> Option<BuildJob<'t>> {
        if self.build != Build::Waiting {
            return None;
        }
        let spare = self.spare.take()?;
        self.build = Build::Lent;
        Some(BuildJob { spare, waypoints: self.building.clone() })
    }

    /// The build back: the switch follows at the next perception step ([`Self::take_built`]).
    pub fn give_back_build(&mut self, job: BuildJob<'t>, built: bool) {
        self.spare = Some(job.spare);
        if self.build == Build::Lent {
            self.build = Build::Built(built);
        }
    }

    /// The switch to an offer built aside, when its build came back (`None`: none did); as
    /// [`Self::take_offer`] otherwise.
    pub fn take_built(&mut self, c: &mut impl Crew<'t>) -> Option<Result<(), Option<Keep>>> {
        let Build::Built(built) = self.build else {
            return None;
        };
        self.build = Build::Idle;
        Some(self.switch_to_spare(c, built))
    }

    /// The switch to the tube built in the spare storage (`built`: it built).
    fn switch_to_spare(&mut self, c: &mut impl Crew<'t>, built: bool) -> Result<(), Option<Keep>> {
        let spare = self.spare.as_mut().filter(|_| built).ok_or(None)?;
        let r = c.switch_tube(spare).map_err(Some);
        self.declined = r.is_err();
        if r.is_ok() {
            self.map.handed_over();
        }
        r
    }

    /// The planner's period: companion `team.id` of `team.n` re-plans when it is the lowest
    /// healthy id ([`designated_planner`]) and a re-plan is due at `now_ms`, from the load at
    /// `load_m`. A plan is offered when it is worth a switch and holds every member position
    /// of `team` by the flown `r_safe`; with no route and the tube blocked within
    /// [`HOLD_AHEAD_M`] of the load, the team holds.
    pub fn plan<H, T>(&mut self, c: &impl Crew<'t>, team: TeamView<H, T>, load_m: &Vec3, now_ms: u32) -> Planned<'_>
    where
        H: Fn(usize) -> bool,
        T: Iterator<Item = vt_tube::Vec2>,
    {
        let Some((prepared, backoff)) = self.begin(c, &team.healthy, team.id, team.n, load_m, now_ms) else {
            return Planned::Idle;
        };
        let searched = match (prepared, self.space.as_deref_mut(), self.check.as_deref_mut()) {
            (Ok(p), Some(space), Some(check)) => search(space, check, &p),
            (Ok(_), _, _) => Searched::failed(PlanError::BadParams { field: "planner space lent" }),
            (Err(e), _, _) => Searched::failed(e),
        };
        self.conclude(c, team.positions_m, load_m, searched, backoff)
    }

    /// [`Self::plan`] for a board that plans aside: a due re-plan is prepared and waits for
    /// [`Self::lend`]; the search that came back ([`Self::give_back`]) is checked and offered
    /// now, against the team as it is now. `Idle` in between.
    pub fn plan_aside<H, T>(&mut self, c: &impl Crew<'t>, team: TeamView<H, T>, load_m: &Vec3, now_ms: u32) -> Planned<'_>
    where
        H: Fn(usize) -> bool,
        T: Iterator<Item = vt_tube::Vec2>,
    {
        if let Some((result, backoff)) = self.done.take() {
            return self.conclude(c, team.positions_m, load_m, result, backoff);
        }
        if self.ready.is_some() || self.lent.is_some() {
            return Planned::Idle;
        }
        match self.begin(c, &team.healthy, team.id, team.n, load_m, now_ms) {
            None => Planned::Idle,
            Some((Ok(p), backoff)) => {
                self.ready = Some((p, backoff));
                Planned::Idle
            }
            Some((Err(e), backoff)) => self.conclude(c, team.positions_m, load_m, Searched::failed(e), backoff),
        }
    }

    /// The prepared search with the planner's work space, for a task of lower priority to run
    /// (`None`: nothing waits).
    pub fn lend(&mut self) -> Option<PlanJob<'p>> {
        let (prepared, backoff) = self.ready?;
        let (space, check) = (self.space.take()?, self.check.take());
        let Some(check) = check else {
            self.space = Some(space);
            return None;
        };
        self.ready = None;
        self.lent = Some(backoff);
        Some(PlanJob { space, check, prepared })
    }

    /// A lent search back, with what it found: checked and offered at the next perception step.
    pub fn give_back(&mut self, job: PlanJob<'p>, searched: Searched) {
        self.space = Some(job.space);
        self.check = Some(job.check);
        if let Some(backoff) = self.lent.take() {
            self.done = Some((searched, backoff));
        }
    }

    /// A re-plan due now from this planner: prepared on the map (the start, the map's cells in
    /// the work space), with its back-off (`None`: not the planner, no tube, not due, or the
    /// work space is lent).
    fn begin(&mut self, c: &impl Crew<'t>, healthy: &impl Fn(usize) -> bool, id: usize, n: usize, load_m: &Vec3, now_ms: u32) -> Option<(Result<Prepared, PlanError>, f32)> {
        if designated_planner(n, healthy) != Some(id) {
            return None;
        }
        let tube = c.tube()?;
        if !self.map.replan_due(now_ms) {
            return None;
        }
        let space = self.space.as_deref_mut()?;
        let backoff = if core::mem::take(&mut self.from_load) { 0.0 } else { BACKOFF_M };
        let need_m = c.need_half_width_m(load_m);
        Some((self.map.prepare(tube, load_m, backoff, need_m, now_ms, space), backoff))
    }

    /// The check of a search's result: offered when worth a switch and holding every member
    /// of `positions_m` by the flown `r_safe` plus the hand-over; kept otherwise; with no route
    /// and the tube blocked within [`HOLD_AHEAD_M`] of the load, the team holds.
    fn conclude(&mut self, c: &impl Crew<'t>, positions_m: impl Iterator<Item = vt_tube::Vec2>, load_m: &Vec3, searched: Searched, backoff: f32) -> Planned<'_> {
        let Some(tube) = c.tube() else {
            return Planned::Failed;
        };
        match searched.result {
            Ok(waypoints) => {
                let worth = self.map.worth_switching(tube, &waypoints, load_m);
                self.offer = waypoints;
                let built = searched.check_built && self.check.is_some();
                let holds = worth && built && self.check.as_deref().is_some_and(|k| holds_team(k, positions_m, hold_margin_m(c.r_safe_m(), c.v_max_mps())));
                if !hand_over_now(worth, holds) {
                    // Needed but a member is outside it: the team stands ahead of the back-off
                    // point where the new route leaves the old one. The next plan starts at the
                    // load, whose start disc holds the formation around it.
                    self.from_load = worth && backoff > 0.0;
                    return Planned::Kept;
                }
                let route_again = self.declared_no_route || c.team_no_route();
                self.declared_no_route = false;
                Planned::Offer { waypoints: &self.offer, route_again }
            }
            Err(PlanError::TooNarrow { .. } | PlanError::InsideObstacle { .. }) if self.map.blocked_ahead_m(load_s(tube, load_m)) < HOLD_AHEAD_M => {
                self.declared_no_route = true;
                Planned::NoRoute
            }
            Err(_) => Planned::Failed,
        }
    }
}

/// The load's arc length along `tube`, m (0 when it cannot be placed).
fn load_s(tube: &CompanionTube, load_m: &Vec3) -> f32 {
    tube.locate(load_m.xy(), 0).map_or(0.0, |sec| sec.s_m)
}

#[cfg(test)]
#[path = "replanning_tests.rs"]
mod tests;
