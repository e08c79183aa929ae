//! The one mission loop every backend flies through (SIL with the crates, SIL with the
//! firmware's companion twin, PIL with the firmware in QEMU).
//!
//! Per plant step: when the low level is due, the [`World`] measures (a [`Tick`]) and the
//! [`Team`] answers with one attitude setpoint per UAV; the world then advances one plant step
//! under the setpoints it holds. Rates, sensing and the order of events are the world's; what
//! differs between backends is only how the setpoints are computed.

pub mod replan;
pub mod scans;
pub mod team;
pub mod world;

pub use team::{holding_of, phase_of, Beacon, refusal_of, refusal_text_of, team_mode_of, CompanionTeam, Meas, Report, Setpoint, Team, TeamStart, Tick};
pub use world::World;

use crate::record::RunRecord;
use crate::scenario::LoadedScenario;
use crate::sim::{ControllerKind, RunOptions, SimError};
use crate::summary::Summary;
use std::time::Instant;

/// What a flight produced.
#[derive(Debug, Clone)]
pub struct Flown {
    /// Metrics.
    pub summary: Summary,
    /// Time histories (empty unless recording).
    pub record: RunRecord,
}

/// Flies `ls` with `team` under `opts` (`kind`: the controller the team flies, for the report).
///
/// # Errors
/// The world cannot be built, the team refuses its configuration, or a backend fails.
pub fn fly(ls: &LoadedScenario, opts: &RunOptions, team: &mut dyn Team) -> Result<Flown, SimError> {
    // The plant the options ask for becomes the scenario's: every backend (and the tuning
    // that depends on the UAV model) then reads one scenario.
    let with_plant;
    let ls = if opts.uav_model.is_some() || opts.cable_model.is_some() {
        let mut l = ls.clone();
        l.scenario.uavs.model = opts.uav_model.unwrap_or(l.scenario.uavs.model);
        l.scenario.cables.model = opts.cable_model.unwrap_or(l.scenario.cables.model);
        with_plant = l;
        &with_plant
    } else {
        ls
    };
    let mut world = World::new(ls, opts)?;
    // Pre-flight: the team hovers at take-off and its computers survey their measurements
    // (docs/design.md, "Take-off survey"); then the take-off measurement and the start.
    let (takeoff, cable_rated_n) = (world.takeoff().clone(), world.cable_rated_n());
    while world.preflight_due() {
        let tick = world.measure();
        team.preflight(ls, &TeamStart { tick, takeoff: &takeoff, cable_rated_n })?;
        world.advance_preflight()?;
    }
    if let Some(reason) = team.start(ls, &world.start())? {
        let seed = opts.seed.unwrap_or(ls.scenario.seed);
        return Ok(Flown { summary: Summary::refused(&ls.scenario, opts.controller.name(), seed, reason), record: RunRecord::default() });
    }
    let n = ls.scenario.cables.lengths_m.len();
    let mut setpoints = vec![Setpoint { q_ned: [1.0, 0.0, 0.0, 0.0], thrust: 0.0 }; n];
    let bar = crate::sim::progress_bar(opts.progress, world.max_steps(), "{spinner} simulating [{bar:40}] {percent:>3}% (time limit) {elapsed}");
    let wall = Instant::now();
    let mut tube_version = 0;
    if let Some((version, tube)) = team.published_tube() {
        tube_version = version;
        world.set_team_tube(tube);
    }
    while !world.done() {
        if world.low_level_due() {
            // What each UAV broadcasts travels with its position (team failsafe).
            team.team_modes(world.team_mode_slots());
            let tick = world.measure();
            team.step(&tick, &mut setpoints)?;
            let (phases, refusals) = world.phase_slots();
            team.phases(phases, refusals);
            if opts.record {
                world.set_holding(&team.holding());
                let (vel_cmd, f_hat) = world.controller_slots();
                team.controller_outputs(vel_cmd, f_hat);
            }
        }
        if let Some((version, tube)) = team.published_tube() {
            if version != tube_version {
                tube_version = version;
                world.set_team_tube(tube);
            }
        }
        world.advance(&setpoints);
        if world.step_count() % 2000 == 0 {
            if let Some(b) = &bar {
                b.set_position(world.step_count());
            }
        }
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let kind: ControllerKind = opts.controller;
    let load_path_m = world.load_path_m();
    let (mut summary, record) = world.finish(kind, wall.elapsed().as_secs_f64(), team.invalid_commands(), |uav| team.refusal_text(uav));
    if let Some(r) = team.replan_stats() {
        summary.perception(ls, &r, load_path_m);
    }
    Ok(Flown { summary, record })
}
