//! Perception campaigns (issue 28): every run flies its own unknown forest. The campaign's
//! `[forest]` table draws the trunks of run `seed` (`vt_sim::map::forest`, splitmix64: the
//! same seed gives the same field on every machine) into the level's `[world]`, whose team
//! knows only the bounds, the start and the goal (`[perception] map = "unknown"`) and maps it
//! with its LiDARs. A flood-fill oracle on the true field (`corridor_exists`, independent of
//! the planner) says which fields are solvable, so the success rate is counted where a route
//! exists and a hold (`no_route`) is the right outcome where none does.
//!
//! ```toml
//! [forest]
//! trunks = [12, 32]        # trunks per field, uniform in this range (inclusive)
//! radius_m = [0.4, 1.0]    # trunk radius, uniform, m
//! keep_clear_m = 8.0       # no trunk within this distance of the plan's start and goal, m
//! ```

use super::{err, Row};
use crate::map::forest::{corridor_exists, forest};
use crate::map::{LoadedMap, Map, Shape};
use crate::scenario::{self, LoadedScenario, MapKnowledge, ScenarioError};
use serde::{Deserialize, Serialize};

/// A campaign's `[forest]` table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForestSpec {
    /// Trunks per field, drawn uniformly in `[min, max]`.
    pub trunks: [usize; 2],
    /// Trunk radius range, m.
    pub radius_m: [f64; 2],
    /// No trunk within this distance of the plan's start and goal, m.
    pub keep_clear_m: f64,
}

impl ForestSpec {
    /// Reads `[forest]` of campaign file `source`.
    ///
    /// # Errors
    /// A missing or bad field, named `forest.<field>`.
    pub fn parse(v: &toml::Value, source: &str) -> Result<Self, ScenarioError> {
        let t = v.as_table().ok_or_else(|| err(source, Some("forest"), "must be a table".into()))?;
        if let Some(k) = t.keys().find(|k| !["trunks", "radius_m", "keep_clear_m"].contains(&k.as_str())) {
            return Err(err(source, Some(&format!("forest.{k}")), "unknown field (trunks, radius_m, keep_clear_m)".into()));
        }
        let pair = |key: &str| -> Result<[f64; 2], ScenarioError> {
            let bad = || err(source, Some(&format!("forest.{key}")), "must be two numbers [min, max] with 0 <= min <= max".into());
            let a = t.get(key).and_then(toml::Value::as_array).ok_or_else(bad)?;
            let xs: Vec<f64> = a.iter().filter_map(|x| x.as_float().or_else(|| x.as_integer().map(|i| i as f64))).collect();
            match xs.as_slice() {
                [lo, hi] if xs.len() == a.len() && lo.is_finite() && hi.is_finite() && *lo >= 0.0 && lo <= hi => Ok([*lo, *hi]),
                _ => Err(bad()),
            }
        };
        let trunks = pair("trunks")?;
        if trunks.iter().any(|x| x.fract() != 0.0 || *x > 500.0) {
            return Err(err(source, Some("forest.trunks"), "must be whole numbers of at most 500".into()));
        }
        let radius_m = pair("radius_m")?;
        if radius_m[0] <= 0.0 {
            return Err(err(source, Some("forest.radius_m"), "must be > 0".into()));
        }
        let keep_clear_m = match t.get("keep_clear_m") {
            None => 8.0,
            Some(v) => v
                .as_float()
                .or_else(|| v.as_integer().map(|i| i as f64))
                .filter(|x| x.is_finite() && *x >= 0.0)
                .ok_or_else(|| err(source, Some("forest.keep_clear_m"), "must be a number >= 0".into()))?,
        };
        Ok(Self { trunks: [trunks[0] as usize, trunks[1] as usize], radius_m, keep_clear_m })
    }

    /// The number of trunks of run `seed`.
    fn trunks_of(&self, seed: u64) -> usize {
        // splitmix64's first draw from the seed (the forest's own stream starts from the seed
        // too; this count only sets how many trunks it places).
        let z = crate::map::forest::next(&mut { seed });
        let span = (self.trunks[1] - self.trunks[0]) as u64 + 1;
        self.trunks[0] + (z % span) as usize
    }
}

/// The oracle's verdict on a field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// A corridor of the planner's need plus one lattice step joins start and goal.
    Solvable,
    /// Not even a corridor of the need less one lattice step: the team must hold.
    NoRoute,
    /// In between: within the planner's resolution of the need.
    Marginal,
}

impl Verdict {
    /// The verdict as `sweep.csv` and `sweep.json` spell it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Solvable => "solvable",
            Self::NoRoute => "no_route",
            Self::Marginal => "marginal",
        }
    }
}

/// What a forest run flew over.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct FieldClass {
    /// Trunks drawn.
    pub trunks: usize,
    /// The oracle's verdict.
    pub verdict: Verdict,
}

/// The scenario of run `seed` over `base` (the level's scenario, and `table` its merged TOML):
/// its `[world]` obstacles replaced by the seed's forest, through the same parser and
/// validation as a hand-written file; and the oracle's verdict on it.
///
/// # Errors
/// The base does not re-plan in flight (`[perception] map = "unknown"` and `[tube] plan`), or
/// the drawn scenario fails validation.
pub fn field_of(base: &LoadedScenario, table: &toml::Table, spec: &ForestSpec, seed: u64) -> Result<(LoadedScenario, FieldClass), String> {
    let s = &base.scenario;
    let plan = s.tube.plan.as_ref().filter(|_| s.perception.map == MapKnowledge::Unknown).ok_or_else(|| {
        format!("{}: a [forest] campaign needs a base whose map is unknown ([perception] map = \"unknown\", [tube] plan)", base.scenario.name)
    })?;
    let n = spec.trunks_of(seed);
    let field = forest(seed, n, s.world.bounds_m, spec.radius_m, &[plan.start, plan.goal], spec.keep_clear_m);
    let Map::Geometric { shapes, .. } = &field else {
        return Err("the forest generator gave a grid".into());
    };
    let obstacles: Vec<toml::Value> = shapes
        .iter()
        .filter_map(|sh| match sh {
            Shape::Circle { center_m, radius_m } => {
                let mut o = toml::Table::new();
                o.insert("center_m".into(), toml::Value::Array(center_m.iter().map(|x| toml::Value::Float(*x)).collect()));
                o.insert("radius_m".into(), toml::Value::Float(*radius_m));
                Some(toml::Value::Table(o))
            }
            _ => None,
        })
        .collect();
    let mut t = table.clone();
    let world = t.entry("world").or_insert_with(|| toml::Value::Table(toml::Table::new()));
    if let toml::Value::Table(w) = world {
        w.insert("obstacles".into(), toml::Value::Array(obstacles));
    }
    let name = format!("{} forest {seed}", s.name);
    let text = toml::to_string(&t).map_err(|e| e.to_string())?;
    let ls = scenario::parse(&text, &name).map_err(|e| e.to_string())?;
    let p = crate::plan::params_of(&ls.scenario, plan);
    let need = p.need_half_width_m + p.margin_m;
    let trunks = shapes.len();
    let truth = LoadedMap { source_name: name, map: field.clone() };
    let verdict = if corridor_exists(&truth, plan.start, plan.goal, need + p.lattice_m) {
        Verdict::Solvable
    } else if corridor_exists(&truth, plan.start, plan.goal, need - p.lattice_m) {
        Verdict::Marginal
    } else {
        Verdict::NoRoute
    };
    Ok((ls, FieldClass { trunks, verdict }))
}

/// A perception campaign's outcomes at one level, by the oracle's verdict.
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct ForestStats {
    /// Level value.
    pub level: Option<f64>,
    /// Solvable fields flown, and how many succeeded (with the scenario's floors).
    pub solvable: usize,
    /// Solvable fields that succeeded.
    pub solvable_successes: usize,
    /// Solvable fields the team held in (a false `no_route`: the map as seen closed a route).
    pub solvable_held: usize,
    /// Fields with no route, and how many ended in the team holding (`no_route`).
    pub no_route: usize,
    /// Fields with no route where the team held.
    pub no_route_held: usize,
    /// Marginal fields (the oracle cannot tell at the planner's resolution), and successes.
    pub marginal: usize,
    /// Marginal fields that succeeded.
    pub marginal_successes: usize,
    /// Runs where a UAV body, the load or a cable touched a trunk (surface clearance below 0).
    pub contacts: usize,
    /// Runs where a UAV centre or the load left the tube the team flew.
    pub out_of_tube: usize,
    /// The smallest surface clearance to a trunk over the level's runs, m.
    pub min_obstacle_clearance_m: f64,
    /// successes / solvable fields.
    pub solvable_success_rate: f64,
}

/// Per level, the outcomes of a perception campaign's rows (empty for other campaigns).
pub fn forest_stats(level_values: &[Option<f64>], rows: &[Row]) -> Vec<ForestStats> {
    let mut out = Vec::new();
    for lv in level_values {
        let these: Vec<(&Row, Verdict)> = rows.iter().filter(|r| r.level == *lv).filter_map(|r| r.field.as_ref().map(|f| (r, f.verdict))).collect();
        if these.is_empty() {
            continue;
        }
        let count = |v: Verdict, f: &dyn Fn(&Row) -> bool| these.iter().filter(|(r, w)| *w == v && f(r)).count();
        let held = |r: &Row| r.summary.outcome == "no_route";
        let mut st = ForestStats {
            level: *lv,
            solvable: count(Verdict::Solvable, &|_| true),
            solvable_successes: count(Verdict::Solvable, &|r| r.summary.success),
            solvable_held: count(Verdict::Solvable, &held),
            no_route: count(Verdict::NoRoute, &|_| true),
            no_route_held: count(Verdict::NoRoute, &held),
            marginal: count(Verdict::Marginal, &|_| true),
            marginal_successes: count(Verdict::Marginal, &|r| r.summary.success),
            contacts: these.iter().filter(|(r, _)| r.summary.min_obstacle_clearance_m < 0.0).count(),
            out_of_tube: these.iter().filter(|(r, _)| super::left_the_tube(&r.summary)).count(),
            min_obstacle_clearance_m: these.iter().map(|(r, _)| r.summary.min_obstacle_clearance_m).fold(f64::INFINITY, f64::min),
            solvable_success_rate: 0.0,
        };
        st.solvable_success_rate = if st.solvable > 0 { st.solvable_successes as f64 / st.solvable as f64 } else { 0.0 };
        out.push(st);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> (LoadedScenario, toml::Table) {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/forest-3uav-unknown.toml");
        let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{e}"));
        (scenario::parse(&text, path).unwrap_or_else(|e| panic!("{e}")), toml::from_str(&text).unwrap_or_else(|e| panic!("{e}")))
    }

    fn spec(text: &str) -> Result<ForestSpec, ScenarioError> {
        let v: toml::Table = toml::from_str(text).unwrap_or_else(|e| panic!("{e}"));
        ForestSpec::parse(&v["forest"], "c.toml")
    }

    #[test]
    fn bad_forest_tables_name_their_field() {
        let ok = spec("[forest]\ntrunks = [12, 32]\nradius_m = [0.4, 1.0]\n").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(ok, ForestSpec { trunks: [12, 32], radius_m: [0.4, 1.0], keep_clear_m: 8.0 });
        for (text, field) in [
            ("[forest]\nradius_m = [0.4, 1.0]\n", "forest.trunks"),
            ("[forest]\ntrunks = [32, 12]\nradius_m = [0.4, 1.0]\n", "forest.trunks"),
            ("[forest]\ntrunks = [1.5, 3]\nradius_m = [0.4, 1.0]\n", "forest.trunks"),
            ("[forest]\ntrunks = [12, 32]\nradius_m = [0.0, 1.0]\n", "forest.radius_m"),
            ("[forest]\ntrunks = [12, 32]\nradius_m = [0.4, 1.0, 2.0]\n", "forest.radius_m"),
            ("[forest]\ntrunks = [12, 32]\nradius_m = [0.4, 1.0]\nkeep_clear_m = -1.0\n", "forest.keep_clear_m"),
            ("[forest]\ntrunks = [12, 32]\nradius_m = [0.4, 1.0]\ntrunk = 3\n", "forest.trunk"),
        ] {
            let e = spec(text).expect_err(text);
            assert_eq!(e.field.as_deref(), Some(field), "{e}");
        }
        let v: toml::Table = toml::from_str("forest = 3").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(ForestSpec::parse(&v["forest"], "c.toml").map_err(|e| e.field), Err(Some("forest".into())));
    }

    #[test]
    fn each_seed_draws_its_own_field_the_same_everywhere_and_the_oracle_judges_it() {
        let (ls, table) = base();
        let sp = ForestSpec { trunks: [12, 32], radius_m: [0.4, 1.0], keep_clear_m: 8.0 };
        let (a, fa) = field_of(&ls, &table, &sp, 111).unwrap_or_else(|e| panic!("{e}"));
        let (b, fb) = field_of(&ls, &table, &sp, 111).unwrap_or_else(|e| panic!("{e}"));
        let (c, _) = field_of(&ls, &table, &sp, 112).unwrap_or_else(|e| panic!("{e}"));
        let centres = |l: &LoadedScenario| l.scenario.world.obstacles.iter().map(|o| (o.center_m, o.radius_m)).collect::<Vec<_>>();
        assert_eq!(centres(&a), centres(&b));
        assert_eq!(fa, fb);
        assert_ne!(centres(&a), centres(&c));
        assert_eq!(fa.trunks, a.scenario.world.obstacles.len());
        assert!((12..=32).contains(&fa.trunks));
        // The field replaces the base's trunks, keeps everything else, and keeps its terminals clear.
        assert_ne!(centres(&a), centres(&ls));
        assert_eq!(a.scenario.uavs.mass_kg, ls.scenario.uavs.mass_kg);
        let plan = a.scenario.tube.plan.as_ref().map(|p| (p.start, p.goal));
        for (c, r) in centres(&a) {
            for t in [plan.map(|p| p.0), plan.map(|p| p.1)].into_iter().flatten() {
                assert!((c[0] - t[0]).hypot(c[1] - t[1]) > 8.0 + r);
            }
        }
        // The verdict is the oracle's on the drawn trunks.
        let shapes = a.scenario.world.obstacles.iter().map(|o| Shape::Circle { center_m: o.center_m, radius_m: o.radius_m }).collect();
        let truth = LoadedMap { source_name: "t".into(), map: Map::Geometric { bounds_m: a.scenario.world.bounds_m, shapes } };
        let p = crate::plan::params_of(&a.scenario, a.scenario.tube.plan.as_ref().unwrap_or_else(|| panic!("plan")));
        let wide = corridor_exists(&truth, [2.0, 12.0], [38.0, 12.0], p.need_half_width_m + p.margin_m + p.lattice_m);
        assert_eq!(fa.verdict == Verdict::Solvable, wide);
        for v in [Verdict::Solvable, Verdict::NoRoute, Verdict::Marginal] {
            assert_eq!(serde_json::to_value(v).ok().and_then(|j| j.as_str().map(str::to_string)).as_deref(), Some(v.name()), "csv and json agree");
        }
    }

    #[test]
    fn a_known_map_base_is_refused() {
        let (ls, table) = base();
        let sp = ForestSpec { trunks: [12, 12], radius_m: [0.4, 1.0], keep_clear_m: 8.0 };
        assert!(field_of(&ls, &table, &sp, 1).is_ok());
        let mut known = ls.clone();
        known.scenario.perception.map = MapKnowledge::Known;
        let e = field_of(&known, &table, &sp, 1).expect_err("known map");
        assert!(e.contains("map is unknown"), "{e}");
    }
}
