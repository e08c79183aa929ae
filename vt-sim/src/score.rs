//! Scoring a trajectory flown elsewhere (`host-sim score TRAJECTORY.csv SCENARIO`, issue 26):
//! the rows of a `trajectory.csv` in host-sim's own format ([`crate::record::trajectory_csv`])
//! pass through the same [`Metrics`] as a host-sim flight, so another simulator's flight (RotorPy,
//! `host-sim sitl --plant rotorpy`) is judged by the same floors and summary keys.
//!
//! Differences from a host-sim flight, by construction: every metric is taken on every row (the
//! host takes the safety distances at the high-level rate and the tensions at the plant rate);
//! the thrust fraction is the recorded thrust over `[uavs] thrust_max_n` (the host records the
//! commanded collective); a cable breaks when its recorded tension first exceeds the scenario's
//! breaking strength; the formation error at the end is measured against the formation of the
//! first row (the take-off).

use crate::models::UavModel;
use crate::metrics::{formation_error, FlightEnd, Metrics, TubeHints};
use crate::record::RunRecord;
use crate::scenario::{LoadedScenario, SIM_MAX_UAVS};
use crate::sim::{self, ControllerKind};
use crate::summary::{CableBreak, Summary};
use nalgebra::Vector3;
use std::path::Path;
use vt_dissipative::Formation;

type V3 = Vector3<f64>;

/// Input that cannot be scored: the message names the file, the line and the column.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreError(pub String);

impl std::fmt::Display for ScoreError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ScoreError {}

/// What flew the trajectory, for the summary.
#[derive(Debug, Clone, Copy)]
pub struct Provenance {
    /// `summary.json` `plant` (`rotorpy`, or `external` for a file of unknown origin).
    pub plant: &'static str,
    /// `summary.json` `uav_model`.
    pub uav_model: &'static str,
    /// `summary.json` `cable_model`.
    pub cable_model: &'static str,
    /// Controller the team flew.
    pub controller: ControllerKind,
    /// Wall time of the flight, s (0: unknown).
    pub wall_s: f64,
}

/// One row of the trajectory.
#[derive(Debug, Clone)]
struct Row {
    time_s: f64,
    uav_pos_m: Vec<V3>,
    uav_vel_mps: Vec<V3>,
    thrust_n: Vec<f64>,
    tension_n: Vec<f64>,
    load_pos_m: V3,
    load_vel_mps: V3,
}

/// The columns of one UAV, in host-sim's order.
const UAV_COLUMNS: [&str; 8] = ["x_m", "y_m", "z_m", "vx_mps", "vy_mps", "vz_mps", "thrust_n", "tension_n"];
/// The load's columns.
const LOAD_COLUMNS: [&str; 6] = ["load_x_m", "load_y_m", "load_z_m", "load_vx_mps", "load_vy_mps", "load_vz_mps"];

/// Column indices of the fields the score reads.
struct Columns {
    time: usize,
    uav: Vec<[usize; 8]>,
    load: [usize; 6],
}

impl Columns {
    fn find(header: &csv::StringRecord, n: usize, source: &str) -> Result<Self, ScoreError> {
        let find = |name: &str| {
            header.iter().position(|h| h.trim() == name).ok_or_else(|| ScoreError(format!("{source}:1: column `{name}` missing (the scenario has {n} UAVs)")))
        };
        if let Some(extra) = header.iter().find(|h| h.trim() == format!("uav{n}_x_m")) {
            return Err(ScoreError(format!("{source}:1: column `{extra}`: the trajectory has more UAVs than the scenario's {n}")));
        }
        let mut uav = Vec::with_capacity(n);
        for i in 0..n {
            let mut cols = [0usize; 8];
            for (c, name) in cols.iter_mut().zip(UAV_COLUMNS) {
                *c = find(&format!("uav{i}_{name}"))?;
            }
            uav.push(cols);
        }
        let mut load = [0usize; 6];
        for (c, name) in load.iter_mut().zip(LOAD_COLUMNS) {
            *c = find(name)?;
        }
        Ok(Self { time: find("time_s")?, uav, load })
    }

    fn row(&self, rec: &csv::StringRecord, header: &csv::StringRecord, line: u64, source: &str) -> Result<Row, ScoreError> {
        let get = |c: usize| -> Result<f64, ScoreError> {
            let name = header.get(c).unwrap_or("?");
            let text = rec.get(c).ok_or_else(|| ScoreError(format!("{source}:{line}: column `{name}` missing in this row")))?;
            // Non-finite values are accepted: a plant that diverged wrote them (reported as
            // `nonfinite`, not as bad input).
            text.trim().parse::<f64>().map_err(|_| ScoreError(format!("{source}:{line}: column `{name}`: `{text}` is not a number")))
        };
        let v3 = |c: &[usize]| -> Result<V3, ScoreError> { Ok(V3::new(get(c[0])?, get(c[1])?, get(c[2])?)) };
        let mut row = Row {
            time_s: get(self.time)?,
            uav_pos_m: Vec::with_capacity(self.uav.len()),
            uav_vel_mps: Vec::with_capacity(self.uav.len()),
            thrust_n: Vec::with_capacity(self.uav.len()),
            tension_n: Vec::with_capacity(self.uav.len()),
            load_pos_m: v3(&self.load[0..3])?,
            load_vel_mps: v3(&self.load[3..6])?,
        };
        for cols in &self.uav {
            row.uav_pos_m.push(v3(&cols[0..3])?);
            row.uav_vel_mps.push(v3(&cols[3..6])?);
            row.thrust_n.push(get(cols[6])?);
            row.tension_n.push(get(cols[7])?);
        }
        Ok(row)
    }
}

fn finite(r: &Row) -> bool {
    let v = |x: &V3| x.iter().all(|c| c.is_finite());
    r.uav_pos_m.iter().all(v) && r.uav_vel_mps.iter().all(v) && v(&r.load_pos_m) && v(&r.load_vel_mps) && r.tension_n.iter().all(|t| t.is_finite())
}

/// Scores the trajectory in `path` against `ls`.
///
/// # Errors
/// The file cannot be read, or a column, a value or the time order is wrong (file:line:column).
pub fn score_file(path: &Path, ls: &LoadedScenario, from: &Provenance) -> Result<(Summary, RunRecord), ScoreError> {
    let text = std::fs::read_to_string(path).map_err(|e| ScoreError(format!("{}: {e}", path.display())))?;
    score_text(&text, &path.display().to_string(), ls, from)
}

/// Scores a trajectory given as CSV text (`source` names it in errors).
///
/// # Errors
/// As [`score_file`].
pub fn score_text(text: &str, source: &str, ls: &LoadedScenario, from: &Provenance) -> Result<(Summary, RunRecord), ScoreError> {
    let s = &ls.scenario;
    let n = s.cables.lengths_m.len();
    let mut reader = csv::ReaderBuilder::new().has_headers(true).trim(csv::Trim::All).from_reader(text.as_bytes());
    let header = reader.headers().map_err(|e| ScoreError(format!("{source}:1: {e}")))?.clone();
    let cols = Columns::find(&header, n, source)?;
    let rated = s.cables.rated_n;
    let breaking = s.cables.breaking_strength_n();
    let thrust_max = s.uavs.thrust_max_n;
    let model = if from.uav_model == UavModel::PointMass.name() { UavModel::PointMass } else { UavModel::RigidBody };
    let (clearances, judge) = crate::clearance::Clearances::for_flight(ls, model);
    let mut metrics = Metrics::new(n, rated, s, ls.tube.length_m(), clearances, judge);
    metrics.set_rated(rated);
    let mut record = RunRecord {
        scenario: s.name.clone(),
        controller: from.controller.name().into(),
        f_max_n: rated,
        load_altitude_ref_m: s.load.altitude_m,
        rated_n: rated,
        tray_height_m: s.controller.tray_height_m,
        ..RunRecord::default()
    };
    let record_dt = 1.0 / f64::from(s.rates.record_hz.max(1));
    let (mut hints, lost) = (TubeHints::new(n), vec![false; n]);
    let mut broken = vec![false; n];
    let mut first: Option<Row> = None;
    let mut last: Option<Row> = None;
    let mut completion = None;
    let mut next_record = f64::NEG_INFINITY;
    for (k, rec) in reader.records().enumerate() {
        let line = k as u64 + 2;
        let rec = rec.map_err(|e| ScoreError(format!("{source}:{line}: {e}")))?;
        let row = cols.row(&rec, &header, line, source)?;
        if let Some(prev) = &last {
            if row.time_s.is_nan() || row.time_s <= prev.time_s {
                return Err(ScoreError(format!("{source}:{line}: column `time_s`: {} does not follow {} (times must increase)", row.time_s, prev.time_s)));
            }
        }
        if !finite(&row) {
            metrics.nonfinite = true;
            last = Some(row);
            break;
        }
        let t = row.time_s;
        metrics.geometry(t, &row.uav_pos_m, &row.load_pos_m, &ls.tube, &mut hints, &lost);
        if metrics.arrived && completion.is_none() {
            completion = Some(t);
        }
        for (i, (&tension, b)) in row.tension_n.iter().zip(broken.iter_mut()).enumerate() {
            if tension > breaking && !*b {
                *b = true;
                metrics.breaks.push(CableBreak { uav: i, time_s: t, tension_n: tension, breaking_n: breaking });
            }
        }
        let attached: Vec<bool> = broken.iter().map(|b| !b).collect();
        metrics.clearances.sample(&row.uav_pos_m, &row.load_pos_m, &lost, &attached, &ls.tube);
        metrics.tensions(&row.tension_n);
        metrics.tension_sample(&row.tension_n);
        if thrust_max > 0.0 {
            metrics.max_thrust_fraction = row.thrust_n.iter().fold(metrics.max_thrust_fraction, |a, &f| a.max(f / thrust_max));
        }
        if t >= next_record {
            next_record = t + record_dt * (1.0 - 1e-9);
            push_record(&mut record, &row, &metrics);
        }
        if first.is_none() {
            first = Some(row.clone());
        }
        last = Some(row);
    }
    let (Some(first), Some(last)) = (first, last) else {
        return Err(ScoreError(format!("{source}: no rows after the header")));
    };
    let formation = {
        let f32v = |v: &V3| Vector3::new(v.x as f32, v.y as f32, v.z as f32);
        let own: Vec<Vector3<f32>> = first.uav_pos_m.iter().map(f32v).collect();
        Formation::<SIM_MAX_UAVS>::from_takeoff(&own, &f32v(&first.load_pos_m), &sim::tray(s)).ok()
    };
    let formation_err = match (&formation, metrics.nonfinite) {
        (Some(f), false) => formation_error(&last.uav_pos_m, &last.load_pos_m, f, &sim::tray(s)),
        _ => f64::NAN,
    };
    let end = FlightEnd {
        kind: from.controller,
        seed: s.seed,
        sim_s: last.time_s,
        wall_s: from.wall_s,
        formation_error: formation_err,
        capacity_margin: sim::takeoff(s, &ls.tube, rated).capacity_margin,
        completion,
        shortened: false,
        uav_model: from.uav_model,
        cable_model: from.cable_model,
    };
    let mut summary = metrics.finish(s, &end);
    summary.plant = from.plant.into();
    Ok((summary, record))
}

fn push_record(rec: &mut RunRecord, row: &Row, m: &Metrics) {
    let a = |v: &V3| [v.x, v.y, v.z];
    rec.time_s.push(row.time_s);
    rec.uav_pos_m.push(row.uav_pos_m.iter().map(a).collect());
    rec.uav_vel_mps.push(row.uav_vel_mps.iter().map(a).collect());
    rec.thrust_n.push(row.thrust_n.clone());
    rec.tension_n.push(row.tension_n.clone());
    rec.load_pos_m.push(a(&row.load_pos_m));
    rec.load_vel_mps.push(a(&row.load_vel_mps));
    rec.min_uav_boundary_m.push(m.now_uav_boundary());
    rec.min_load_boundary_m.push(m.now_load_boundary());
    rec.min_uav_uav_m.push(m.now_uav_uav());
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::trajectory_csv;
    use crate::sim::{run, RunOptions};

    fn from() -> Provenance {
        Provenance { plant: "external", uav_model: "rigid_body", cable_model: "elastic", controller: ControllerKind::Dissipative, wall_s: 0.0 }
    }

    fn experiment() -> LoadedScenario {
        crate::scenario::load(Some(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/experiment-3uav.toml")))).expect("scenario")
    }

    #[test]
    fn a_host_flight_scores_as_it_flew() {
        // The host's own record (20 Hz) scored again: same verdict, distances within what the
        // coarser sampling can miss.
        let ls = experiment();
        let out = run(&ls, &RunOptions { record: true, ..RunOptions::default() }).expect("flight");
        let (scored, record) = score_text(&trajectory_csv(&out.record), "host.csv", &ls, &from()).expect("score");
        assert_eq!(scored.success, out.summary.success);
        assert!(scored.success, "{:?}", scored.failures);
        assert!((scored.min_uav_uav_m - out.summary.min_uav_uav_m).abs() < 0.05, "{} vs {}", scored.min_uav_uav_m, out.summary.min_uav_uav_m);
        assert!((scored.min_uav_boundary_m - out.summary.min_uav_boundary_m).abs() < 0.05);
        assert!(scored.min_uav_uav_m >= out.summary.min_uav_uav_m - 1e-9, "a sub-sample of the flight cannot come closer");
        let dt = (scored.completion_time_s.unwrap_or(0.0) - out.summary.completion_time_s.unwrap_or(1e9)).abs();
        assert!(dt <= 0.05 + 1e-9, "arrival {dt} s apart");
        assert_eq!(scored.plant, "external");
        assert_eq!(record.time_s.len(), out.record.time_s.len());
    }

    #[test]
    fn a_trajectory_leaving_the_tube_fails() {
        let ls = experiment();
        let out = run(&ls, &RunOptions { record: true, ..RunOptions::default() }).expect("flight");
        let mut rec = out.record.clone();
        let k = rec.uav_pos_m.len() / 2;
        rec.uav_pos_m[k][1][1] += 30.0;
        let (scored, _) = score_text(&trajectory_csv(&rec), "moved.csv", &ls, &from()).expect("score");
        assert!(!scored.success);
        assert!(scored.min_uav_boundary_m < 0.0);
    }

    #[test]
    fn bad_input_names_file_line_and_column() {
        let ls = experiment();
        let out = run(&ls, &RunOptions { record: true, duration_s: Some(1.0), ..RunOptions::default() }).expect("flight");
        let csv = trajectory_csv(&out.record);
        let e = score_text(&csv.replacen("uav2_z_m", "uav2_height", 1), "t.csv", &ls, &from()).expect_err("missing column");
        assert!(e.0.starts_with("t.csv:1: column `uav2_z_m` missing"), "{e}");
        let mut lines: Vec<String> = csv.lines().map(String::from).collect();
        let mut fields: Vec<&str> = lines[3].split(',').collect();
        fields[1] = "abc";
        lines[3] = fields.join(",");
        let e = score_text(&lines.join("\n"), "t.csv", &ls, &from()).expect_err("bad number");
        assert!(e.0.starts_with("t.csv:4: column `uav0_x_m`: `abc` is not a number"), "{e}");
        let mut lines: Vec<String> = csv.lines().map(String::from).collect();
        lines.swap(3, 4);
        let e = score_text(&lines.join("\n"), "t.csv", &ls, &from()).expect_err("time order");
        assert!(e.0.starts_with("t.csv:5: column `time_s`"), "{e}");
        let e = score_text(csv.lines().next().unwrap_or(""), "t.csv", &ls, &from()).expect_err("empty");
        assert!(e.0.contains("no rows"), "{e}");
    }
}
