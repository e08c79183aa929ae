//! Campaigns: a base scenario plus overrides, flown over many seeds (and optionally over a
//! list of disturbance levels), in parallel. Results: per-run rows and aggregate statistics.
//!
//! A campaign file is TOML with `base` (a scenario path relative to the campaign file, or
//! `"builtin:paper-10uav"`), optional `runs` and `seed` (first seed), optional
//! `[levels] key = "disturbances.intensity"`, `values = [...]`, and any scenario tables to
//! merge over the base (`[disturbances]`, `[[faults]]`, `[load]`, ...). A plain scenario file
//! is a campaign of itself. With `generate = true` every run flies its own generated scenario
//! (`vt_sim::scenario::generate`, from the run's seed, over the level's merged scenario): tube,
//! team, airframe, cables and load are drawn; gains, rates, link and disturbances are the
//! campaign's. With `declare_wind = true` every run declares its wind as a forecast would
//! (`[mission] max_wind_mps` = the mean wind, `gust_margin_mps` = two gust standard deviations,
//! at the run's intensity); a team that cannot hold it is refused before take-off and the row
//! says so (`outcome = "refused"`). `world` (`"real_aircraft"`, the default, or `"scenario"`)
//! says which world the base is flown in ([`world`]); a plain scenario file flies as written.

use crate::scenario::{self, LoadedScenario, ScenarioError};
use crate::sim::{self, RunOptions};
use crate::summary::Summary;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub mod forest;
pub mod shard;
pub mod world;
pub use shard::{merge, ShardFile, ShardSpec};
pub use world::World;

/// Keys of a campaign file that are not scenario fields.
const CAMPAIGN_KEYS: [&str; 8] = ["base", "runs", "seed", "levels", "generate", "declare_wind", "forest", "world"];

/// A loaded campaign.
#[derive(Debug, Clone)]
pub struct Campaign {
    /// Name (the merged scenario's name).
    pub name: String,
    /// Scenario at each level (one entry, level `None`, without `[levels]`).
    pub levels: Vec<(Option<f64>, LoadedScenario)>,
    /// Dotted key the levels set.
    pub level_key: Option<String>,
    /// Runs per level (default).
    pub runs: usize,
    /// First seed.
    pub seed: u64,
    /// Each run flies the scenario generated from its seed over its level's table.
    pub generate: bool,
    /// Each run declares its level's wind before take-off (refused above the team's capacity).
    pub declare_wind: bool,
    /// Each run flies its own unknown forest (`[forest]`, [`forest`]).
    pub forest: Option<forest::ForestSpec>,
    /// The merged scenario table of each level (what the generator draws over).
    pub tables: Vec<toml::Table>,
    /// The world the base is flown in ([`World::Scenario`] for a plain scenario file).
    pub world: World,
}

fn err(source: &str, field: Option<&str>, message: String) -> ScenarioError {
    ScenarioError { source_name: source.into(), line: None, field: field.map(str::to_string), message }
}

/// Deep-merges `over` into `base` (tables merge; anything else replaces).
fn merge_tables(base: &mut toml::Table, over: &toml::Table) {
    for (k, v) in over {
        match (base.get_mut(k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge_tables(b, o),
            _ => {
                base.insert(k.clone(), v.clone());
            }
        }
    }
}

fn set_dotted(t: &mut toml::Table, key: &str, value: f64) -> bool {
    fn set(v: &mut toml::Value, parts: &[&str], value: f64) -> bool {
        let Some((first, rest)) = parts.split_first() else {
            // Keep integers integers (e.g. a UAV index), everything else a float.
            *v = match v {
                toml::Value::Integer(_) if value.fract() == 0.0 => toml::Value::Integer(value as i64),
                _ => toml::Value::Float(value),
            };
            return true;
        };
        match v {
            toml::Value::Table(t) => {
                let entry = t.entry(first.to_string()).or_insert_with(|| {
                    if rest.is_empty() { toml::Value::Float(value) } else { toml::Value::Table(toml::Table::new()) }
                });
                set(entry, rest, value)
            }
            toml::Value::Array(a) => first.parse::<usize>().ok().and_then(|i| a.get_mut(i)).is_some_and(|e| set(e, rest, value)),
            _ => false,
        }
    }
    let parts: Vec<&str> = key.split('.').collect();
    let mut root = toml::Value::Table(std::mem::take(t));
    let ok = set(&mut root, &parts, value);
    if let toml::Value::Table(back) = root {
        *t = back;
    }
    ok
}

/// Loads a campaign file, or a scenario file as a one-level campaign, or the built-in
/// scenario when `path` is `None`.
///
/// # Errors
/// Unreadable files, TOML errors, unknown campaign structure, and scenario validation errors
/// (naming the field; lines refer to the file that holds it when it is a plain scenario).
pub fn load(path: Option<&Path>) -> Result<Campaign, ScenarioError> {
    load_in(path, None)
}

/// [`load`], flying a campaign file's base in `world` instead of the file's `world` key (a
/// plain scenario file, or the built-in one, always flies as written).
///
/// # Errors
/// As [`load`].
pub fn load_in(path: Option<&Path>, world: Option<World>) -> Result<Campaign, ScenarioError> {
    let Some(path) = path else {
        let ls = scenario::load(None)?;
        let tables = vec![toml::from_str(scenario::PAPER_10UAV).map_err(|e| err(scenario::DEFAULT_SCENARIO_NAME, None, e.to_string()))?];
        return Ok(Campaign { name: ls.scenario.name.clone(), levels: vec![(None, ls)], level_key: None, runs: 20, seed: 1, generate: false, declare_wind: false, forest: None, tables, world: World::Scenario });
    };
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| err(&name, None, format!("cannot read: {e}")))?;
    let table: toml::Table = toml::from_str(&text).map_err(|e| ScenarioError {
        source_name: name.clone(),
        line: e.span().map(|s| text.get(..s.start).map_or(0, |t| t.matches('\n').count()) + 1),
        field: None,
        message: e.message().trim().to_string(),
    })?;
    let Some(base) = table.get("base") else {
        let ls = scenario::parse(&text, &name)?;
        let seed = ls.scenario.seed;
        return Ok(Campaign { name: ls.scenario.name.clone(), levels: vec![(None, ls)], level_key: None, runs: 20, seed, generate: false, declare_wind: false, forest: None, tables: vec![table], world: World::Scenario });
    };
    let base = base.as_str().ok_or_else(|| err(&name, Some("base"), "must be a path string".into()))?;
    let (base_text, base_name) = if base == "builtin:paper-10uav" {
        (scenario::PAPER_10UAV.to_string(), scenario::DEFAULT_SCENARIO_NAME.to_string())
    } else {
        let p = path.parent().unwrap_or(Path::new(".")).join(base);
        let t = std::fs::read_to_string(&p).map_err(|e| err(&name, Some("base"), format!("cannot read {}: {e}", p.display())))?;
        (t, p.display().to_string())
    };
    let mut merged: toml::Table = toml::from_str(&base_text).map_err(|e| err(&base_name, None, e.message().to_string()))?;
    if base != "builtin:paper-10uav" {
        // A planned base names its map relative to itself; the merged scenario's source is the
        // campaign, so the map path is made absolute here (issue 16).
        let base_dir = path.parent().unwrap_or(Path::new(".")).join(base);
        let base_dir = base_dir.parent().and_then(|d| std::fs::canonicalize(d).ok());
        if let (Some(dir), Some(toml::Value::Table(tube))) = (base_dir, merged.get_mut("tube")) {
            if let Some(toml::Value::Table(plan)) = tube.get_mut("plan") {
                if let Some(toml::Value::String(m)) = plan.get_mut("map") {
                    *m = dir.join(m.as_str()).display().to_string();
                }
            }
        }
    }
    let mut over = table.clone();
    for k in CAMPAIGN_KEYS {
        over.remove(k);
    }
    // A campaign that gives the tube one way replaces the base's other way (plan vs waypoints).
    if let (Some(toml::Value::Table(bt)), Some(toml::Value::Table(ot))) = (merged.get_mut("tube"), over.get("tube")) {
        if ot.contains_key("plan") {
            bt.remove("waypoints");
        }
        if ot.contains_key("waypoints") {
            bt.remove("plan");
        }
    }
    // Likewise the take-off layout: a ring's radius or one node per cable (a packed team, issue
    // 27's heaviest loads).
    if let (Some(toml::Value::Table(bu)), Some(toml::Value::Table(ou))) = (merged.get_mut("uavs"), over.get("uavs")) {
        if ou.contains_key("formation_offsets_m") {
            bu.remove("formation_radius_m");
        }
        if ou.contains_key("formation_radius_m") {
            bu.remove("formation_offsets_m");
        }
    }
    let world = match (world, table.get("world")) {
        (Some(w), _) => w,
        (None, None) => World::default(),
        (None, Some(v)) => v.as_str().ok_or_else(|| "must be a string".to_string()).and_then(World::parse).map_err(|m| err(&name, Some("world"), m))?,
    };
    let flag = |key: &str| match table.get(key) {
        None => Ok(false),
        Some(v) => v.as_bool().ok_or_else(|| err(&name, Some(key), "must be true or false".into())),
    };
    let (generate, declare_wind) = (flag("generate")?, flag("declare_wind")?);
    // The world is chosen on the base with the campaign's own tables (its airframe or plant
    // may be the campaign's), and merged under them.
    let mut probe = merged.clone();
    merge_tables(&mut probe, &over);
    let world_table = world.overlay(&probe, generate, &name)?;
    merge_tables(&mut merged, &world_table);
    merge_tables(&mut merged, &over);
    let runs = match table.get("runs") {
        None => 20,
        Some(v) => v.as_integer().filter(|r| *r > 0).ok_or_else(|| err(&name, Some("runs"), "must be an integer > 0".into()))? as usize,
    };
    let seed = match table.get("seed") {
        None => 1,
        Some(v) => v.as_integer().filter(|r| *r >= 0).ok_or_else(|| err(&name, Some("seed"), "must be an integer >= 0".into()))? as u64,
    };
    let forest = table.get("forest").map(|v| forest::ForestSpec::parse(v, &name)).transpose()?;
    if generate && forest.is_some() {
        return Err(err(&name, Some("forest"), "a campaign either generates its missions or draws forests, not both".into()));
    }
    let source = format!("{name} (over {base_name})");
    let (level_key, values) = match table.get("levels") {
        None => (None, vec![None]),
        Some(toml::Value::Table(l)) => {
            let key = l.get("key").and_then(|k| k.as_str()).ok_or_else(|| err(&name, Some("levels.key"), "must be a dotted field name".into()))?;
            let values: Vec<f64> = l
                .get("values")
                .and_then(|v| v.as_array())
                .map(|a| a.iter().filter_map(|x| x.as_float().or_else(|| x.as_integer().map(|i| i as f64))).collect())
                .filter(|v: &Vec<f64>| !v.is_empty())
                .ok_or_else(|| err(&name, Some("levels.values"), "must be a non-empty list of numbers".into()))?;
            (Some(key.to_string()), values.into_iter().map(Some).collect())
        }
        Some(_) => return Err(err(&name, Some("levels"), "must be a table".into())),
    };
    let (mut levels, mut tables) = (Vec::new(), Vec::new());
    for v in values {
        let mut t = merged.clone();
        if let (Some(k), Some(v)) = (&level_key, v) {
            if !set_dotted(&mut t, k, v) {
                return Err(err(&name, Some("levels.key"), format!("`{k}` is not a settable field")));
            }
        }
        let text = toml::to_string(&t).map_err(|e| err(&name, None, e.to_string()))?;
        // Validation messages name the field; the merged text's lines are not the user's, so
        // they are dropped.
        let ls = scenario::parse(&text, &source).map_err(|e| ScenarioError { line: None, ..e })?;
        levels.push((v, ls));
        tables.push(t);
    }
    let mut name = levels.first().map_or_else(String::new, |(_, l)| l.scenario.name.clone());
    if generate {
        name = format!("generated over {name}");
    }
    if forest.is_some() {
        name = format!("unknown forests over {name}");
    }
    if !world_table.is_empty() {
        name = format!("{name} in the real-aircraft world");
    }
    Ok(Campaign { name, levels, level_key, runs, seed, generate, declare_wind, forest, tables, world })
}

/// One run's row of `sweep.csv`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Row {
    /// Disturbance level (if the campaign has levels).
    pub level: Option<f64>,
    /// The run's summary.
    pub summary: Summary,
    /// What was generated for the run (generated campaigns only).
    #[serde(default)]
    pub class: Option<RunClass>,
    /// The forest the run flew and the oracle's verdict (perception campaigns only).
    #[serde(default)]
    pub field: Option<forest::FieldClass>,
}

/// The class of a generated run's scenario, for the per-class tables.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RunClass {
    /// Tube shape.
    pub tube: String,
    /// Team size.
    pub n_uavs: usize,
    /// Airframe class.
    pub airframe: String,
    /// Load over the team's vertical capacity at take-off.
    pub load_fraction: f64,
    /// All cables the same length.
    pub equal_cables: bool,
    /// Draws that failed validation before this one.
    pub redraws: u32,
    /// The team's capacity against the forecast's mean plus its gust margin, m/s
    /// (`vt_dissipative::wind::WindCapacity::with_gust_max_mps`: what the companions' check
    /// accepts).
    #[serde(default, deserialize_with = "crate::summary::f64_or_nan")]
    pub wind_capacity_mps: f64,
    /// The wind the run flies in, as a forecast would declare it: mean plus two gust standard
    /// deviations, at the run's intensity, m/s.
    #[serde(default, deserialize_with = "crate::summary::f64_or_nan")]
    pub wind_mps: f64,
}

impl RunClass {
    /// The class of generated scenario `g`.
    fn of(g: &scenario::generate::Generated) -> Self {
        let d = &g.drawn;
        let s = &g.loaded.scenario;
        let (mean, gust) = forecast_mps(s);
        let cap = sim::wind_check(s, s.cables.rated_n, 0.0, 0.0).map_or(f64::NAN, |c| f64::from(c.with_gust_max_mps(gust as f32)));
        Self {
            tube: d.tube.name().into(),
            n_uavs: d.n_uavs,
            airframe: d.airframe.name.into(),
            load_fraction: d.load_fraction,
            equal_cables: d.equal_cables,
            redraws: d.redraws,
            wind_capacity_mps: cap,
            wind_mps: mean + gust,
        }
    }

    /// The run's wind is beyond what the team can hold (it would be refused if declared).
    pub fn beyond_wind_capacity(&self) -> bool {
        self.wind_mps > self.wind_capacity_mps
    }
}

/// The wind a forecast declares for `s`: its mean horizontal wind and two gust standard
/// deviations, at its intensity, m/s.
pub fn forecast_mps(s: &scenario::Scenario) -> (f64, f64) {
    let d = &s.disturbances;
    (d.intensity * d.wind_mean_mps[0].hypot(d.wind_mean_mps[1]), d.intensity * 2.0 * d.gust_std_mps)
}

/// Why `s` is refused before take-off with its forecast declared (the companions' wind check,
/// `sim::wind_preflight`), or `None` when the team holds it.
fn wind_refusal(s: &scenario::Scenario) -> Option<String> {
    let (mean, gust) = forecast_mps(s);
    sim::wind_check(s, s.cables.rated_n, mean as f32, gust as f32).err().map(|e| e.to_string())
}

/// What run `(level l, seed)` flies: its scenario, the generated class, the forest field.
pub type RunScenario<'a> = (std::borrow::Cow<'a, LoadedScenario>, Option<RunClass>, Option<forest::FieldClass>);

/// The scenario run `(level l, seed)` of `c` flies: the level's, or the one generated from the
/// seed over the level's table.
///
/// # Errors
/// No valid generated draw (the generator's last validation error).
pub fn scenario_of(c: &Campaign, l: usize, seed: u64) -> Result<RunScenario<'_>, String> {
    if let Some(spec) = &c.forest {
        let (t, (_, base)) = c.tables.get(l).zip(c.levels.get(l)).ok_or_else(|| format!("level {l} is not in campaign {}", c.name))?;
        let (ls, field) = forest::field_of(base, t, spec, seed)?;
        return Ok((std::borrow::Cow::Owned(ls), None, Some(field)));
    }
    if c.generate {
        let t = c.tables.get(l).ok_or_else(|| format!("level {l} is not in campaign {}", c.name))?;
        let g = scenario::generate::generate(t, seed).map_err(|e| e.to_string())?;
        let class = RunClass::of(&g);
        Ok((std::borrow::Cow::Owned(g.loaded), Some(class), None))
    } else {
        let (_, ls) = c.levels.get(l).ok_or_else(|| format!("level {l} is not in campaign {}", c.name))?;
        Ok((std::borrow::Cow::Borrowed(ls), None, None))
    }
}

/// Flies `runs` seeds (`seed`, `seed + 1`, ...) at every level on `jobs` threads.
/// Results come back in (level, seed) order whatever the scheduling.
///
/// # Errors
/// A crate rejecting the scenario (as for a single run).
pub fn fly(c: &Campaign, runs: usize, seed: u64, jobs: usize, progress: bool) -> Result<Vec<Row>, String> {
    Ok(fly_shard(c, runs, seed, jobs, progress, None)?.into_iter().map(|(_, r)| r).collect())
}

/// The campaign's work in (level, seed) order: level index and seed of every run; run `i` of
/// the list is the campaign's run number `i` (what [`ShardSpec`] slices).
pub fn work(levels: usize, runs: usize, seed: u64) -> Vec<(usize, u64)> {
    (0..levels).flat_map(|l| (0..runs as u64).map(move |k| (l, seed + k))).collect()
}

/// [`fly`] for one shard of the work (`None`: all of it): each row with its run number.
///
/// # Errors
/// As [`fly`].
pub fn fly_shard(c: &Campaign, runs: usize, seed: u64, jobs: usize, progress: bool, shard: Option<ShardSpec>) -> Result<Vec<(usize, Row)>, String> {
    let work: Vec<(usize, (usize, u64))> =
        work(c.levels.len(), runs, seed).into_iter().enumerate().filter(|(i, _)| shard.is_none_or(|s| s.owns(*i))).collect();
    let bar = sim::progress_bar(progress, work.len() as u64, "sweep [{bar:40}] {pos}/{len} runs {elapsed}");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(jobs.max(1)).build().map_err(|e| e.to_string())?;
    let rows: Result<Vec<(usize, Row)>, String> = pool.install(|| {
        work.par_iter()
            .map(|&(i, (l, s))| {
                let level = c.levels.get(l).and_then(|(lv, _)| *lv);
                let (ls, class, field) = scenario_of(c, l, s)?;
                let summary = match c.declare_wind.then(|| wind_refusal(&ls.scenario)).flatten() {
                    Some(reason) => Summary::refused(&ls.scenario, sim::ControllerKind::Dissipative.name(), s, reason),
                    None => sim::run(&ls, &RunOptions { seed: Some(s), record: false, ..RunOptions::default() }).map_err(|e| e.to_string())?.summary,
                };
                if let Some(b) = &bar {
                    b.inc(1);
                }
                Ok((i, Row { level, summary, class, field }))
            })
            .collect()
    });
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    rows
}

/// The run `sweep --replay-worst` re-flies (issue 17), in (level, seed) order: the first run
/// that left the tube, refused or not (a team refused on the ground still takes off and lands:
/// the safety failure to look at), else the first failed accepted run, else the flown run with
/// the smallest minimum UAV-boundary distance. Runs refused before take-off (nothing flew) are
/// skipped. `None` without a flown row.
pub fn worst(rows: &[Row]) -> Option<&Row> {
    let flew = || rows.iter().filter(|r| r.summary.sim_time_s > 0.0);
    flew()
        .find(|r| left_the_tube(&r.summary))
        .or_else(|| flew().find(|r| !r.summary.was_refused() && !r.summary.success))
        .or_else(|| flew().min_by(|a, b| a.summary.min_uav_boundary_m.total_cmp(&b.summary.min_uav_boundary_m)))
}

/// Flies `row`'s run again (same level, same seed) with recording on, for its replay: campaign
/// runs keep no time histories. Deterministic, so it is the same flight (tests/determinism.rs).
///
/// # Errors
/// The row's level is not in the campaign, or a crate rejects the scenario.
pub fn refly(c: &Campaign, row: &Row) -> Result<sim::RunOutput, String> {
    let l = c
        .levels
        .iter()
        .position(|(l, _)| l.map(f64::to_bits) == row.level.map(f64::to_bits))
        .ok_or_else(|| format!("level {:?} is not in campaign {}", row.level, c.name))?;
    let (ls, _, _) = scenario_of(c, l, row.summary.seed)?;
    sim::run(&ls, &RunOptions { seed: Some(row.summary.seed), record: true, ..RunOptions::default() }).map_err(|e| e.to_string())
}

/// Percentiles of one metric.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Percentiles {
    /// Minimum.
    pub min: f64,
    /// 5th percentile.
    pub p5: f64,
    /// Median.
    pub p50: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Maximum.
    pub max: f64,
}

fn percentiles(mut xs: Vec<f64>) -> Option<Percentiles> {
    xs.retain(|x| x.is_finite());
    if xs.is_empty() {
        return None;
    }
    xs.sort_by(f64::total_cmp);
    let q = |p: f64| xs[((p * (xs.len() - 1) as f64).round() as usize).min(xs.len() - 1)];
    Some(Percentiles { min: xs[0], p5: q(0.05), p50: q(0.5), p95: q(0.95), max: xs[xs.len() - 1] })
}

/// Aggregate of one level.
#[derive(Debug, Clone, Serialize)]
pub struct LevelStats {
    /// Level value (`null` without levels).
    pub level: Option<f64>,
    /// Runs.
    pub runs: usize,
    /// Successful runs.
    pub successes: usize,
    /// successes / runs.
    pub success_rate: f64,
    /// Percentiles of the summary metrics.
    pub percentiles: std::collections::BTreeMap<&'static str, Percentiles>,
    /// How often each failure reason occurred (first words of the reason).
    pub failure_reasons: std::collections::BTreeMap<String, usize>,
    /// Runs where a UAV centre or the load left the tube (a boundary distance below 0).
    pub out_of_tube: usize,
    /// Runs refused before take-off (declared wind above the team's capacity), or on the
    /// ground (a ground start's arming or lift).
    pub refused: usize,
    /// Ground starts that set the load down before the end: the team could not hold the tube
    /// (outcome `set_down`).
    pub set_down: usize,
    /// successes / (runs - refused): the success rate among the runs the team accepted.
    pub accepted_success_rate: f64,
}

/// One class of generated scenarios at one level.
#[derive(Debug, Clone, Serialize)]
pub struct ClassStats {
    /// What is grouped (`tube`, `airframe`, `team`, `load`, `wind`: within or beyond the
    /// team's wind capacity).
    pub dimension: &'static str,
    /// The class (`s_bend`, `light-1.47kg-30N`, `10-19`, `60-80 %`, ...).
    pub class: String,
    /// Level value.
    pub level: Option<f64>,
    /// Runs, successes, and runs out of the tube.
    pub runs: usize,
    /// Successful runs.
    pub successes: usize,
    /// Runs where a UAV or the load left the tube.
    pub out_of_tube: usize,
    /// Runs refused before take-off.
    pub refused: usize,
    /// Failure reasons and their counts.
    pub failure_reasons: std::collections::BTreeMap<String, usize>,
}

/// A run left the tube: a UAV centre or the load beyond a boundary.
pub fn left_the_tube(s: &Summary) -> bool {
    s.min_uav_boundary_m < 0.0 || s.min_load_boundary_m < 0.0
}

/// The class a generated run falls in along `dimension`.
fn class_of(dimension: &str, c: &RunClass) -> String {
    match dimension {
        "tube" => c.tube.clone(),
        "airframe" => c.airframe.clone(),
        "wind" => if c.beyond_wind_capacity() { "beyond capacity".into() } else { "within capacity".into() },
        "team" => match c.n_uavs {
            0..=9 => "3-9".into(),
            10..=19 => "10-19".into(),
            _ => "20-30".into(),
        },
        _ => match c.load_fraction {
            f if f < 0.6 => "30-60 %".into(),
            f if f < 0.8 => "60-80 %".into(),
            _ => "80-95 %".into(),
        },
    }
}

/// Per-class statistics of a generated campaign's rows (empty for other campaigns).
pub fn class_stats(level_values: &[Option<f64>], rows: &[Row]) -> Vec<ClassStats> {
    let mut out = Vec::new();
    for dimension in ["tube", "airframe", "team", "load", "wind"] {
        let mut classes: Vec<String> = rows.iter().filter_map(|r| r.class.as_ref().map(|c| class_of(dimension, c))).collect();
        classes.sort();
        classes.dedup();
        for class in classes {
            for lv in level_values {
                let these: Vec<&Row> =
                    rows.iter().filter(|r| r.level == *lv && r.class.as_ref().is_some_and(|c| class_of(dimension, c) == class)).collect();
                if these.is_empty() {
                    continue;
                }
                let st = level_stats(*lv, &these);
                out.push(ClassStats {
                    dimension,
                    class: class.clone(),
                    level: *lv,
                    runs: st.runs,
                    successes: st.successes,
                    out_of_tube: st.out_of_tube,
                    refused: st.refused,
                    failure_reasons: st.failure_reasons,
                });
            }
        }
    }
    out
}

/// `sweep.json`.
#[derive(Debug, Clone, Serialize)]
pub struct SweepReport {
    /// Campaign or scenario name.
    pub scenario: String,
    /// Dotted key the levels set, if any.
    pub level_key: Option<String>,
    /// First seed.
    pub first_seed: u64,
    /// Total runs.
    pub runs: usize,
    /// Total successes.
    pub successes: usize,
    /// successes / runs over all levels.
    pub success_rate: f64,
    /// Percentiles over all runs.
    pub percentiles: std::collections::BTreeMap<&'static str, Percentiles>,
    /// Per level.
    pub levels: Vec<LevelStats>,
    /// Per class of generated scenario and level (generated campaigns only).
    pub classes: Vec<ClassStats>,
    /// Redraws of the generator over all runs (draws that failed validation).
    pub redraws: u64,
    /// Per level, the outcomes by the oracle's verdict (perception campaigns only).
    pub forest: Vec<forest::ForestStats>,
}

fn metric_table(rows: &[&Row]) -> std::collections::BTreeMap<&'static str, Percentiles> {
    type Get = fn(&Summary) -> f64;
    let metrics: [(&'static str, Get); 10] = [
        ("min_uav_boundary_m", |s| s.min_uav_boundary_m),
        ("min_load_boundary_m", |s| s.min_load_boundary_m),
        ("min_uav_uav_m", |s| s.min_uav_uav_m),
        ("max_tension_n", |s| s.max_tension_n),
        ("tension_cv_mean", |s| s.tension_cv_mean),
        ("max_load_altitude_error_m", |s| s.max_load_altitude_error_m),
        ("max_thrust_fraction", |s| s.max_thrust_fraction),
        ("formation_error_end_m", |s| s.formation_error_end_m),
        ("completion_time_s", |s| s.completion_time_s.unwrap_or(f64::NAN)),
        ("time_above_rated_fraction", |s| s.time_above_rated_fraction),
    ];
    metrics.iter().filter_map(|(k, f)| percentiles(rows.iter().map(|r| f(&r.summary)).collect()).map(|p| (*k, p))).collect()
}

fn level_stats(level: Option<f64>, rows: &[&Row]) -> LevelStats {
    let successes = rows.iter().filter(|r| r.summary.success).count();
    let refused = rows.iter().filter(|r| r.summary.was_refused()).count();
    let mut reasons = std::collections::BTreeMap::new();
    for r in rows {
        for f in &r.summary.failures {
            // Group by the reason's words, numbers removed.
            let key: String = f
                .split(['(', ':'])
                .next()
                .unwrap_or(f)
                .split_whitespace()
                .filter(|w| !w.chars().any(|c| c.is_ascii_digit()))
                .collect::<Vec<_>>()
                .join(" ");
            *reasons.entry(key).or_insert(0) += 1;
        }
    }
    LevelStats {
        level,
        runs: rows.len(),
        successes,
        success_rate: if rows.is_empty() { 0.0 } else { successes as f64 / rows.len() as f64 },
        percentiles: metric_table(rows),
        failure_reasons: reasons,
        out_of_tube: rows.iter().filter(|r| left_the_tube(&r.summary)).count(),
        refused,
        set_down: rows.iter().filter(|r| r.summary.outcome == "set_down").count(),
        accepted_success_rate: if rows.len() > refused { successes as f64 / (rows.len() - refused) as f64 } else { 0.0 },
    }
}

/// Aggregates the rows.
pub fn report(c: &Campaign, first_seed: u64, rows: &[Row]) -> SweepReport {
    let levels: Vec<Option<f64>> = c.levels.iter().map(|(lv, _)| *lv).collect();
    report_for(&c.name, c.level_key.as_deref(), &levels, first_seed, rows)
}

/// [`report`] from the campaign's identity alone (what `sweep merge` has).
pub fn report_for(name: &str, level_key: Option<&str>, level_values: &[Option<f64>], first_seed: u64, rows: &[Row]) -> SweepReport {
    let all: Vec<&Row> = rows.iter().collect();
    let total = level_stats(None, &all);
    let levels = level_values.iter().map(|lv| level_stats(*lv, &rows.iter().filter(|r| r.level == *lv).collect::<Vec<_>>())).collect();
    SweepReport {
        scenario: name.to_string(),
        level_key: level_key.map(str::to_string),
        first_seed,
        runs: total.runs,
        successes: total.successes,
        success_rate: total.success_rate,
        percentiles: total.percentiles,
        levels,
        classes: class_stats(level_values, rows),
        redraws: rows.iter().filter_map(|r| r.class.as_ref()).map(|c| u64::from(c.redraws)).sum(),
        forest: forest::forest_stats(level_values, rows),
    }
}

/// `sweep.csv`: one row per run.
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "level,seed,success,reached_end,completion_time_s,min_uav_boundary_m,min_load_boundary_m,min_uav_uav_m,max_tension_n,tension_cv_mean,time_at_cap_fraction,max_load_altitude_error_m,max_thrust_fraction,formation_error_end_m,failures,time_above_rated_fraction,true_load_mass_kg,tube,n_uavs,airframe,load_fraction,equal_cables,wind_capacity_mps,wind_mps,outcome,trunks,verdict,min_obstacle_clearance_m\n",
    );
    for r in rows {
        let m = &r.summary;
        s += &format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},\"{}\",{},{},{},{},{},{}\n",
            r.level.map_or(String::new(), |l| l.to_string()),
            m.seed,
            m.success,
            m.reached_end,
            m.completion_time_s.map_or(String::new(), |t| t.to_string()),
            m.min_uav_boundary_m,
            m.min_load_boundary_m,
            m.min_uav_uav_m,
            m.max_tension_n,
            m.tension_cv_mean,
            m.time_at_cap_fraction,
            m.max_load_altitude_error_m,
            m.max_thrust_fraction,
            m.formation_error_end_m,
            m.failures.join("; ").replace('"', "'"),
            m.time_above_rated_fraction,
            m.true_load_mass_kg,
            r.class.as_ref().map_or_else(
                || ",,,,,,".to_string(),
                |c| format!("{},{},{},{},{},{},{}", c.tube, c.n_uavs, c.airframe, c.load_fraction, c.equal_cables, c.wind_capacity_mps, c.wind_mps)
            ),
            m.outcome,
            r.field.as_ref().map_or_else(|| ",".to_string(), |f| format!("{},{}", f.trunks, f.verdict.name())),
            m.min_obstacle_clearance_m,
        );
    }
    s
}

#[cfg(test)]
mod tests;
