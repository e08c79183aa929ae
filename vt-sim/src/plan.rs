//! Tube planning glue (issue 16): the `plan` subcommand and the scenario's
//! `[tube] plan = { map, start, goal }`, which plans before validation so that everything
//! downstream (run, sweep, compare, pil) flies the planned tube unchanged.

use crate::record::PlanScene;
use crate::map::{self, LoadedMap};
use crate::scenario::{Scenario, ScenarioError};
use serde::Deserialize;
use std::path::Path;
use vt_plan::PlannedTube;

/// `[tube] plan = { map = "...", start = [x, y], goal = [x, y] }`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PlanSpec {
    /// Map file (TOML obstacle list or ROS map_server YAML), relative to the scenario's folder;
    /// absent: the scenario's own `[world]` bounds and obstacles.
    #[serde(default)]
    pub map: Option<String>,
    /// Start of the generator curve `[x, y]`, m.
    pub start: [f64; 2],
    /// Goal `[x, y]`, m.
    pub goal: [f64; 2],
    /// Half-width every section must have, m (default `r_active_m + safety_distance_m`; at
    /// least `r_safe_m + safety_distance_m`, Proposition 2).
    #[serde(default)]
    pub min_half_width_m: Option<f64>,
}

/// The map a scenario's plan names (its own `[world]` when `map` is absent).
///
/// # Errors
/// The map file's error.
pub fn scenario_map(s: &Scenario, spec: &PlanSpec, source_name: &str) -> Result<LoadedMap, ScenarioError> {
    match &spec.map {
        None => Ok(LoadedMap::from_world(s, &format!("{source_name} [world]"))),
        Some(m) => {
            let dir = Path::new(source_name).parent().unwrap_or_else(|| Path::new(""));
            LoadedMap::load(&dir.join(m))
        }
    }
}

/// When the scenario's `[tube]` has a `plan`, plans and fills `waypoints` (called by
/// `scenario::parse` before validation); returns the map and the planner's result, kept in
/// [`crate::scenario::LoadedScenario::plan`] for the plots (planned once per load).
///
/// # Errors
/// Both or neither of `waypoints` and `plan`; a bad map; a planner error (too narrow, start or
/// goal outside the map or inside an obstacle), at the line of `plan`.
pub fn fill_planned_tube(s: &mut Scenario, text: &str, source_name: &str) -> Result<Option<PlanScene>, ScenarioError> {
    let line = text.lines().position(|l| {
        let t = l.trim_start();
        t.starts_with("plan ") || t.starts_with("plan=")
    });
    let err = |message: String| ScenarioError {
        source_name: source_name.into(),
        line: line.map(|i| i + 1),
        field: Some("tube.plan".into()),
        message,
    };
    let Some(spec) = s.tube.plan.clone() else {
        return Ok(None);
    };
    if !s.tube.waypoints.is_empty() {
        return Err(err("give either `waypoints` or `plan`, not both".into()));
    }
    if let Some(w) = spec.min_half_width_m {
        let floor = map::prop2_half_width_m(s);
        let max = f64::from(map::params_for(s).max_half_width_m);
        if !(w.is_finite() && w >= floor && w <= max) {
            return Err(err(format!("min_half_width_m must be in [r_safe_m + safety_distance_m = {floor}, {max}] m (got {w})")));
        }
    }
    let params = params_of(s, &spec);
    let m = scenario_map(s, &spec, source_name)?;
    // Issue 28: a team that does not know the map plans before take-off on its bounds alone
    // (the map stays the world's truth: the LiDARs and the clearances measure against it).
    let known = match s.perception.map {
        crate::scenario::MapKnowledge::Known => m.clone(),
        crate::scenario::MapKnowledge::Unknown => LoadedMap { source_name: format!("{} (bounds only)", m.source_name), map: crate::map::Map::Geometric { bounds_m: m.bounds_m(), shapes: Vec::new() } },
    };
    let t = plan_for_team(s, &known, spec.start, spec.goal, &params).map_err(|e| err(format!("{}: {e}", known.source_name)))?;
    Ok(Some(PlanScene { map: m, tube: t }))
}

/// Plans on `m` for the team of `s` (whose `tube.waypoints` it fills with the result): with
/// `params`, then, for a team with bodies flying the formation shaped to the tube, again with
/// the width its separated stadium keeps the floor in when that is more (the team placed on the
/// first plan; docs/design.md, "The width the shaped formation needs").
///
/// # Errors
/// The planner's, naming the shaped formation's width when it asked for it.
fn plan_for_team(s: &mut Scenario, m: &LoadedMap, start: [f64; 2], goal: [f64; 2], params: &vt_plan::PlanParams) -> Result<PlannedTube, String> {
    let t = m.plan(start, goal, params).map_err(|e| e.to_string())?;
    s.tube.waypoints = waypoints_f64(&t);
    let Some(need) = planned_tube(s).and_then(|tube| crate::sim::shaped_need_m(s, &tube)) else {
        return Ok(t);
    };
    if need <= f64::from(params.need_half_width_m) + 1e-4 {
        return Ok(t);
    }
    let mut wider = *params;
    wider.need_half_width_m = need.min(f64::from(params.max_half_width_m)) as f32;
    let t = m.plan(start, goal, &wider).map_err(|e| {
        format!("{e} (bodies declared and the formation shaped to the tube: its pairs keep their floor only in {need:.2} m of half-width; docs/design.md, \"The width the shaped formation needs\")")
    })?;
    s.tube.waypoints = waypoints_f64(&t);
    Ok(t)
}

/// The tube `s.tube.waypoints` give, when vt-tube builds it (`None`: validation says why).
fn planned_tube(s: &Scenario) -> Option<crate::scenario::SimTube> {
    crate::scenario::SimTube::from_waypoints(&s.tube.waypoints_f32()).ok()
}

/// The planner parameters of a scenario's plan: the team's (`map::params_for`) with
/// `min_half_width_m` when given (validated by [`fill_planned_tube`]).
pub fn params_of(s: &Scenario, spec: &PlanSpec) -> vt_plan::PlanParams {
    let mut p = map::params_for(s);
    if let Some(w) = spec.min_half_width_m {
        p.need_half_width_m = w as f32;
    }
    p
}

/// The planned waypoints as the scenario stores them `[x, y, w_L, w_R]`, m: positions on the
/// mission protocol's 0.1 mm grid (the value every companion reconstructs from
/// `MISSION_ITEM_INT`, [`crate::companion::on_wire_grid_m`]; at most 0.05 mm from the plan), so
/// the simulator measures the very tube the companions fly.
pub fn waypoints_f64(t: &PlannedTube) -> Vec<[f64; 4]> {
    use crate::companion::on_wire_grid_m;
    t.waypoints
        .iter()
        .map(|w| [on_wire_grid_m(f64::from(w.pos_m.x)), on_wire_grid_m(f64::from(w.pos_m.y)), f64::from(w.w_left_m), f64::from(w.w_right_m)])
        .collect()
}

/// Parses `X,Y` (metres) for `--start` and `--goal`.
///
/// # Errors
/// Not two finite numbers.
pub fn parse_point(s: &str) -> Result<[f64; 2], String> {
    let mut it = s.split(',').map(|p| p.trim().parse::<f64>());
    match (it.next(), it.next(), it.next()) {
        (Some(Ok(x)), Some(Ok(y)), None) if x.is_finite() && y.is_finite() => Ok([x, y]),
        _ => Err(format!("expected X,Y in metres (two finite numbers), got {s:?}")),
    }
}

/// What `host-sim plan` did.
#[derive(Debug, Clone)]
pub struct PlanOutcome {
    /// The map.
    pub map: LoadedMap,
    /// The tube.
    pub tube: PlannedTube,
    /// The `[tube]` table, TOML.
    pub toml: String,
    /// Planning time (map loading excluded), ms.
    pub plan_ms: f64,
}

/// `host-sim plan`: loads the map and the team, plans, returns the tube.
///
/// # Errors
/// `Err((message, exit code))`: 2 for bad input (map, team, terminals, too narrow).
pub fn run_cli(map_path: &Path, start: [f64; 2], goal: [f64; 2], team: Option<&Path>) -> Result<PlanOutcome, String> {
    let mut team = crate::scenario::load(team).map_err(|e| e.to_string())?;
    let m = LoadedMap::load(map_path).map_err(|e| e.to_string())?;
    let params = map::params_for(&team.scenario);
    let t0 = std::time::Instant::now();
    let tube = plan_for_team(&mut team.scenario, &m, start, goal, &params).map_err(|e| format!("{}: {e}", m.source_name))?;
    let plan_ms = t0.elapsed().as_secs_f64() * 1e3;
    let toml = map::tube_toml(&tube, &m.source_name, start, goal);
    Ok(PlanOutcome { map: m, tube, toml, plan_ms })
}
