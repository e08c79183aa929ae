//! Criterion benchmarks of issue 5 (method and figures: `docs/benchmarks.md`).
//!
//! Groups, all in one run so that their ratios compare like with like:
//! - `control_step/<n>`: one UAV's full control step in a team of `n`: the high-level
//!   dissipative update (tray projection of all neighbours, springs, passing, tube keeping,
//!   tray-centre replica, altitude law) followed by one low-level velocity-loop + CFO update.
//! - `high_level/<n>` and `low_level/step`: the two halves on their own.
//! - `allocation_qp/<n>`: what an optimisation-based method solves instead, each control step:
//!   the cable-tension allocation QP/SOCP (clarabel), warm data (only `q` and `b` change).
//! - `tube_locate/warm` and `tube_locate/cold`: the section lookup `s(q)` along a trajectory
//!   with the previous segment as hint, and from segment 0.
//! - `plant_step/<n>`: one 1 ms plant step (2 sub-steps) of the f64 simulator plant.
//!
//! Teams: the tube of `scenarios/scale-100uav.toml` (wide enough for every n); the formation
//! follows that scenario's rule (node circle radius `max(3, 0.15 n)` m, tray height
//! `R / 0.3` for the paper's take-off lean, the paper's cable lengths scaled with the tray,
//! load `1.8 n` kg for the paper's capacity margin, `k2 = 10 / n`). Each measured call starts
//! from the same warmed state (a clone per iteration, not timed), so the measured path is a
//! steady mid-mission step, not a cold start.
// A benchmark that cannot set itself up has nothing to measure: it stops with a message.
#![allow(clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use std::hint::black_box;
use std::time::Duration;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT};
use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion, SamplingMode};
use host_sim::plant::{LoadParams, Plant, UavParams, GRAVITY_MPS2};
use host_sim::cable::CableParams;
use host_sim::scenario::{Scenario, SimTube};
use host_sim::sim;
use nalgebra::Vector3;
use vt_cfo::VelocityLoop;
use vt_dissipative::{DissipativeController, Formation, Measurements};
use vt_tube::Vec2;

/// Team sizes of the issue.
const TEAM_SIZES: [usize; 4] = [3, 10, 30, 100];
/// Controller capacity for teams that fit the firmware's (`vt_dissipative::MAX_UAVS`).
const CAP_SMALL: usize = vt_dissipative::MAX_UAVS;
/// Controller capacity for larger teams (the simulator's).
const CAP_LARGE: usize = 128;
/// High-level period (paper: 50 Hz), s.
const DT_HIGH_S: f32 = 0.02;
/// Low-level period (paper: 500 Hz), s.
const DT_LOW_S: f32 = 0.002;
/// Plant step (paper: 1 kHz), s.
const DT_PLANT_S: f64 = 1e-3;
/// The paper's ten cable lengths for its 10 m tray, m (REFERENCE §5).
const PAPER_CABLES_M: [f64; 10] = [8.3, 7.0, 8.6, 8.8, 8.3, 8.5, 8.4, 7.7, 8.3, 7.3];
/// Paper formation radius (3 m) and the 100-UAV scenario's node spacing rule, m per UAV.
const PAPER_RADIUS_M: f64 = 3.0;
const RADIUS_PER_UAV_M: f64 = 0.15;
/// Take-off lean tan(atan(R/H)) of the paper: R = 3 m, H = 10 m.
const PAPER_LEAN_TAN: f64 = 0.3;
/// Paper load per UAV, kg (18 kg for 10).
const LOAD_PER_UAV_KG: f64 = 1.8;
/// Allocation QP: half-angle of the cone around vertical each cable force must stay in, rad
/// (30 degrees: room for the paper's 16.7-degree take-off lean and for flattening).
const CONE_HALF_ANGLE_RAD: f64 = std::f64::consts::FRAC_PI_6;
/// Allocation QP: the required load force cycles through this many control steps.
const QP_SEQUENCE: usize = 64;
/// Allocation QP: horizontal acceleration demand on the load, m/s^2 (turning direction).
const QP_ACCEL_MPS2: f64 = 0.5;
/// Clones per timed batch: bounds the working set (each clone is one warmed state).
const BATCH: u64 = 64;

fn scale_scenario() -> Scenario {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/scale-100uav.toml");
    let text = std::fs::read_to_string(path).expect("read scenarios/scale-100uav.toml");
    // Deserialised without host-sim's validation: the teams below are built directly.
    toml::from_str(&text).expect("parse scenarios/scale-100uav.toml")
}

fn tube_of(s: &Scenario) -> SimTube {
    SimTube::from_waypoints(&s.tube.waypoints_f32()).expect("scale-100uav tube is valid")
}

/// The scale scenario re-sized for `n` UAVs by its own rule (see the module doc).
fn team_scenario(base: &Scenario, n: usize) -> Scenario {
    let mut s = base.clone();
    let radius_m = PAPER_RADIUS_M.max(RADIUS_PER_UAV_M * n as f64);
    let tray_m = radius_m / PAPER_LEAN_TAN;
    let cable_scale = tray_m / 10.0;
    s.uavs.formation_radius_m = Some(radius_m);
    s.controller.tray_height_m = tray_m;
    s.controller.k2 = 10.0 / n as f64;
    s.cables.lengths_m = (0..n).map(|i| PAPER_CABLES_M[i % PAPER_CABLES_M.len()] * cable_scale).collect();
    s.load.mass_kg = LOAD_PER_UAV_KG * n as f64;
    s
}

fn v3f(v: &Vector3<f64>) -> Vector3<f32> {
    v.cast::<f32>()
}

/// One UAV (id 0) of a team of `n` at take-off, warmed by one update.
struct Team<const N: usize> {
    tube: SimTube,
    controller: DissipativeController<N>,
    velocity_loop: VelocityLoop,
    own_m: Vector3<f32>,
    load_m: Vector3<f32>,
    neighbours_m: Vec<Option<Vector3<f32>>>,
    f_hat_n: Vector3<f32>,
    v_meas_mps: Vector3<f32>,
}

impl<const N: usize> Team<N> {
    fn new(base: &Scenario, n: usize) -> Self {
        let s = team_scenario(base, n);
        let tube = tube_of(&s);
        let to = sim::takeoff(&s, &tube, s.cables.rated_n);
        let p = host_sim::companion::params_for(&s, 0, sim::ControllerKind::Dissipative, s.cables.rated_n, false).expect("parameters");
        let tray = p.tray();
        let uav_f: Vec<Vector3<f32>> = to.uav_pos_m.iter().map(v3f).collect();
        let load_f = v3f(&to.load_pos_m);
        let formation = Formation::<N>::from_takeoff(&uav_f, &load_f, &tray).expect("formation");
        let cal = vt_dissipative::calibrate(0, &uav_f, &load_f, &p.calibration()).expect("calibration");
        let params = p.dissipative(&cal).expect("dissipative parameters");
        let mut controller = DissipativeController::<N>::new(0, params, &formation).expect("controller");
        let own_m = uav_f[0];
        // The cable pulls UAV 0 towards the load with its share (what the CFO estimates).
        let f_hat_n = (load_f - own_m).normalize() * to.share_n as f32;
        let neighbours_m: Vec<Option<Vector3<f32>>> = uav_f.iter().copied().map(Some).collect();
        let mut velocity_loop = VelocityLoop::new(p.velocity_loop().expect("velocity loop"));
        let v_meas_mps = Vector3::new(0.8, 0.1, 0.0);
        // Warm start: section hints found, observer and integrators past their first steps.
        let m = measurements(own_m, load_f, &neighbours_m, f_hat_n);
        let cmd = controller.update(&tube, &m, DT_HIGH_S);
        for _ in 0..50 {
            velocity_loop.update(cmd.vel_mps, v_meas_mps, DT_LOW_S);
        }
        Self { tube, controller, velocity_loop, own_m, load_m: load_f, neighbours_m, f_hat_n, v_meas_mps }
    }

    fn measurements(&self) -> Measurements<'_> {
        measurements(self.own_m, self.load_m, &self.neighbours_m, self.f_hat_n)
    }
}

/// What UAV 0 knows: own and load position, load moving at 0.8 m/s, every neighbour fresh.
fn measurements(own_m: Vector3<f32>, load_m: Vector3<f32>, neighbours_m: &[Option<Vector3<f32>>], f_hat_n: Vector3<f32>) -> Measurements<'_> {
    Measurements {
        own_pos_m: own_m,
        own_vel_mps: Vector3::zeros(),
        load_pos_m: load_m,
        load_vel_mps: Vector3::new(0.8, 0.1, 0.0),
        neighbours_m,
        neighbours_vel_mps: &[],
        own_cable_force_n: Some(f_hat_n),
    }
}

fn bench_team<const N: usize>(c: &mut Criterion, base: &Scenario, n: usize) {
    let team = Team::<N>::new(base, n);
    let m = team.measurements();
    let mut g = c.benchmark_group("control_step");
    g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
        b.iter_batched_ref(
            || (team.controller.clone(), team.velocity_loop),
            |(hl, ll)| {
                let cmd = hl.update(&team.tube, black_box(&m), DT_HIGH_S);
                black_box(ll.update(cmd.vel_mps, black_box(team.v_meas_mps), DT_LOW_S))
            },
            BatchSize::NumIterations(BATCH),
        );
    });
    g.finish();
    let mut g = c.benchmark_group("high_level");
    g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
        b.iter_batched_ref(
            || team.controller.clone(),
            |hl| black_box(hl.update(&team.tube, black_box(&m), DT_HIGH_S)),
            BatchSize::NumIterations(BATCH),
        );
    });
    g.finish();
}

fn control(c: &mut Criterion) {
    let base = scale_scenario();
    for n in TEAM_SIZES {
        if n <= CAP_SMALL {
            bench_team::<CAP_SMALL>(c, &base, n);
        } else {
            bench_team::<CAP_LARGE>(c, &base, n);
        }
    }
    // The low-level step does not depend on n.
    let team = Team::<CAP_SMALL>::new(&base, 10);
    let cmd = Vector3::new(1.0, 0.2, 0.1);
    c.benchmark_group("low_level").bench_function("step", |b| {
        b.iter_batched_ref(
            || team.velocity_loop,
            |ll| black_box(ll.update(black_box(cmd), black_box(team.v_meas_mps), DT_LOW_S)),
            BatchSize::NumIterations(BATCH),
        );
    });
}

/// The tension allocation an optimisation-based method solves every control step:
/// `min sum |f_i - f_i,prev|^2` over the n cable forces (on the load, N, ENU) subject to
/// `sum f_i = F_req`, `|f_i| <= f_max` and `|f_i,xy| <= tan(theta) f_i,z` (cone around vertical).
struct Allocation {
    solver: DefaultSolver<f64>,
    n: usize,
    requests_n: Vec<Vector3<f64>>,
    step: usize,
    q: Vec<f64>,
    b: Vec<f64>,
    f_max_n: f64,
}

impl Allocation {
    fn new(n: usize, f_max_n: f64) -> Self {
        let vars = 3 * n;
        // P = 2 I (upper triangle), q = -2 f_prev.
        let p = CscMatrix::new(vars, vars, (0..=vars).collect(), (0..vars).collect(), vec![2.0; vars]);
        // Rows: 3 equalities, then per cable 4 (norm cone) + 3 (vertical cone).
        let rows = 3 + 7 * n;
        let tan_cone = CONE_HALF_ANGLE_RAD.tan();
        let mut triplets: Vec<(usize, usize, f64)> = Vec::with_capacity(9 * n);
        for i in 0..n {
            let base = 3 + 7 * i;
            for k in 0..3 {
                triplets.push((k, 3 * i + k, 1.0)); // sum of forces
                triplets.push((base + 1 + k, 3 * i + k, -1.0)); // s = (f_max, f_i)
            }
            triplets.push((base + 4, 3 * i + 2, -tan_cone)); // s = (tan f_z, f_x, f_y)
            triplets.push((base + 5, 3 * i, -1.0));
            triplets.push((base + 6, 3 * i + 1, -1.0));
        }
        let a = csc_from_triplets(rows, vars, &mut triplets);
        let mut cones: Vec<SupportedConeT<f64>> = vec![SupportedConeT::ZeroConeT(3)];
        for _ in 0..n {
            cones.push(SupportedConeT::SecondOrderConeT(4));
            cones.push(SupportedConeT::SecondOrderConeT(3));
        }
        let mass_kg = LOAD_PER_UAV_KG * n as f64;
        let requests_n: Vec<Vector3<f64>> = (0..QP_SEQUENCE)
            .map(|k| {
                let phase = std::f64::consts::TAU * k as f64 / QP_SEQUENCE as f64;
                Vector3::new(QP_ACCEL_MPS2 * phase.cos(), QP_ACCEL_MPS2 * phase.sin(), GRAVITY_MPS2) * mass_kg
            })
            .collect();
        let f0 = requests_n[0] / n as f64;
        let q: Vec<f64> = (0..n).flat_map(|_| [-2.0 * f0.x, -2.0 * f0.y, -2.0 * f0.z]).collect();
        let mut b = vec![0.0; rows];
        b[..3].copy_from_slice(requests_n[0].as_slice());
        for i in 0..n {
            b[3 + 7 * i] = f_max_n;
        }
        let settings = DefaultSettings { verbose: false, presolve_enable: false, ..DefaultSettings::default() };
        let solver = DefaultSolver::new(&p, &q, &a, &b, &cones, settings).expect("allocation problem is well formed");
        Self { solver, n, requests_n, step: 0, q, b, f_max_n }
    }

    /// One control step: new required force, previous solution as the reference, solve.
    fn step(&mut self) -> SolverStatus {
        self.step = (self.step + 1) % QP_SEQUENCE;
        let req = self.requests_n[self.step];
        self.b[..3].copy_from_slice(req.as_slice());
        let x = &self.solver.solution.x;
        if x.len() == self.q.len() && x.iter().all(|v| v.is_finite()) {
            for (qi, xi) in self.q.iter_mut().zip(x.iter()) {
                *qi = -2.0 * xi;
            }
        }
        self.solver.update_q(&self.q).expect("q update");
        self.solver.update_b(&self.b).expect("b update");
        self.solver.solve();
        self.solver.solution.status
    }

    /// Largest constraint violation of the last solution, N.
    fn violation_n(&self) -> f64 {
        let x = &self.solver.solution.x;
        let tan_cone = CONE_HALF_ANGLE_RAD.tan();
        let mut sum = Vector3::zeros();
        let mut worst: f64 = 0.0;
        for i in 0..self.n {
            let f = Vector3::new(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
            sum += f;
            worst = worst.max(f.norm() - self.f_max_n).max(f.xy().norm() - tan_cone * f.z);
        }
        worst.max((sum - Vector3::from_column_slice(&self.b[..3])).amax())
    }
}

fn csc_from_triplets(rows: usize, cols: usize, t: &mut [(usize, usize, f64)]) -> CscMatrix<f64> {
    t.sort_by_key(|&(r, c, _)| (c, r));
    let mut colptr = vec![0usize; cols + 1];
    for &(_, c, _) in t.iter() {
        colptr[c + 1] += 1;
    }
    for c in 0..cols {
        colptr[c + 1] += colptr[c];
    }
    let rowval = t.iter().map(|&(r, _, _)| r).collect();
    let nzval = t.iter().map(|&(_, _, v)| v).collect();
    CscMatrix::new(rows, cols, colptr, rowval, nzval)
}

fn allocation(c: &mut Criterion) {
    let mut g = c.benchmark_group("allocation_qp");
    g.sampling_mode(SamplingMode::Flat).sample_size(20);
    for n in TEAM_SIZES {
        let f_max_n = 20.0;
        let mut alloc = Allocation::new(n, f_max_n);
        // Check once that the problem solves and the solution is feasible.
        for _ in 0..QP_SEQUENCE {
            let status = alloc.step();
            assert!(matches!(status, SolverStatus::Solved | SolverStatus::AlmostSolved), "allocation n = {n}: {status:?}");
            assert!(alloc.violation_n() < 1e-3, "allocation n = {n}: violation {} N", alloc.violation_n());
        }
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| b.iter(|| black_box(alloc.step())));
    }
    g.finish();
}

fn tube_locate(c: &mut Criterion) {
    let tube = tube_of(&scale_scenario());
    // A trajectory along the tube with a lateral weave, 2 mm apart per lookup on average.
    let samples = tube.samples();
    let points: Vec<Vec2> = (0..4096)
        .map(|k| {
            let u = k as f32 / 4096.0 * (samples.len() - 1) as f32;
            let i = (u as usize).min(samples.len() - 2);
            let (a, b) = (&samples[i], &samples[i + 1]);
            let t = u - i as f32;
            let p = a.pos_m + (b.pos_m - a.pos_m) * t;
            let w = 0.5 * (a.w_left_m + a.w_right_m);
            p + a.normal() * (0.6 * w * (k as f32 * 0.01).sin())
        })
        .collect();
    let mut g = c.benchmark_group("tube_locate");
    let (mut k, mut hint) = (0usize, 0usize);
    g.bench_function("warm", |b| {
        b.iter(|| {
            k = (k + 1) % points.len();
            let sec = tube.locate(black_box(points[k]), hint);
            hint = sec.map_or(hint, |s| s.segment);
            black_box(sec)
        })
    });
    let mut k = 0usize;
    g.bench_function("cold", |b| {
        b.iter(|| {
            k = (k + 97) % points.len();
            black_box(tube.locate(black_box(points[k]), 0))
        })
    });
    g.finish();
}

fn plant_step(c: &mut Criterion) {
    let base = scale_scenario();
    let mut g = c.benchmark_group("plant_step");
    for n in [10usize, 100] {
        let s = team_scenario(&base, n);
        let tube = tube_of(&s);
        let to = sim::takeoff(&s, &tube, s.cables.rated_n);
        let uavs = vec![
            UavParams { mass_kg: s.uavs.mass_kg, thrust_max_n: s.uavs.thrust_max_n, thrust_lag_s: s.uavs.thrust_lag_s };
            n
        ];
        let cables: Vec<CableParams> = s
            .cables
            .lengths_m
            .iter()
            .map(|&l| CableParams {
                rest_length_m: l,
                stiffness_n_per_m: s.cables.stiffness_n_per_m,
                damping_ns_per_m: s.cables.damping_ns_per_m,
                f_max_n: s.cables.rated_n,
            })
            .collect();
        let load = LoadParams { mass_kg: s.load.mass_kg };
        let substeps = s.rates.plant_substeps as usize;
        let mut plant = Plant::new(uavs, cables, load, &to.uav_pos_m, to.load_pos_m, substeps).expect("plant");
        let hover = plant.hover_thrust();
        for (u, t) in plant.uavs.iter_mut().zip(&hover) {
            u.thrust_n = *t;
        }
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter_batched_ref(
                || plant.clone(),
                |p| p.step(black_box(&hover), &[], Vector3::zeros(), DT_PLANT_S),
                BatchSize::NumIterations(16),
            );
        });
    }
    g.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .sample_size(50)
}

criterion_group! {
    name = benches;
    config = config();
    targets = control, allocation, tube_locate, plant_step
}
criterion_main!(benches);
