//! Plant tests: equilibrium, energy, momentum, sub-steps, thrust limit and lag, bad input.

use super::*;
use nalgebra::Matrix3;

const DT_S: f64 = 1e-3;
const UAV_MASS_KG: f64 = 2.0;
const LOAD_MASS_KG: f64 = 18.0;
const K_N_PER_M: f64 = 500.0;
const B_NS_PER_M: f64 = 30.0;
const CIRCLE_RADIUS_M: f64 = 3.0;
/// The paper's cable lengths (REFERENCE §5), m.
const PAPER_CABLES_M: [f64; 10] = [8.3, 7.0, 8.6, 8.8, 8.3, 8.5, 8.4, 7.7, 8.3, 7.3];

struct Setup {
    uavs: Vec<UavParams>,
    cables: Vec<CableParams>,
    load: LoadParams,
    uav_pos: Vec<Vector3<f64>>,
}

/// `n` UAVs on a circle of radius 3 m around the load (at the origin), each cable
/// pre-stretched by a little more than its share of the load's weight.
fn setup(n: usize, k: f64, b: f64, f_max: f64, lag_s: f64) -> Setup {
    let uavs = vec![
        UavParams {
            mass_kg: UAV_MASS_KG,
            thrust_max_n: 1e4,
            thrust_lag_s: lag_s
        };
        n
    ];
    let load = LoadParams {
        mass_kg: LOAD_MASS_KG,
    };
    let stretch_m = 1.1 * LOAD_MASS_KG * GRAVITY_MPS2 / (n as f64 * k);
    let mut cables = Vec::new();
    let mut uav_pos = Vec::new();
    for i in 0..n {
        let rest = PAPER_CABLES_M[i % PAPER_CABLES_M.len()];
        cables.push(CableParams {
            rest_length_m: rest,
            stiffness_n_per_m: k,
            damping_ns_per_m: b,
            f_max_n: f_max,
        });
        let th = 2.0 * core::f64::consts::PI * i as f64 / n as f64;
        let len = rest + stretch_m;
        let z = (len * len - CIRCLE_RADIUS_M * CIRCLE_RADIUS_M).sqrt();
        uav_pos.push(Vector3::new(
            CIRCLE_RADIUS_M * th.cos(),
            CIRCLE_RADIUS_M * th.sin(),
            z,
        ));
    }
    Setup {
        uavs,
        cables,
        load,
        uav_pos,
    }
}

fn plant(s: &Setup, load_pos: Vector3<f64>, substeps: usize) -> Plant {
    match Plant::new(
        s.uavs.clone(),
        s.cables.clone(),
        s.load,
        &s.uav_pos,
        load_pos,
        substeps,
    ) {
        Ok(p) => p,
        Err(e) => panic!("setup rejected: {e}"),
    }
}

/// Net static force on the load (N) at `p` with the UAVs fixed at `s.uav_pos`.
fn load_static_force(s: &Setup, p: Vector3<f64>) -> Vector3<f64> {
    let mut f = s.load.mass_kg * gravity_vec_mps2();
    for (q, c) in s.uav_pos.iter().zip(&s.cables) {
        f += cable_force(*q, Vector3::zeros(), p, Vector3::zeros(), c).on_load_n;
    }
    f
}

/// Static equilibrium of the load under fixed UAVs, by Newton's method (cable caps ignored).
fn load_equilibrium(s: &Setup) -> Vector3<f64> {
    let uncapped = Setup {
        uavs: s.uavs.clone(),
        cables: s
            .cables
            .iter()
            .map(|c| CableParams {
                f_max_n: f64::INFINITY,
                ..*c
            })
            .collect(),
        load: s.load,
        uav_pos: s.uav_pos.clone(),
    };
    let s = &uncapped;
    let mut p = Vector3::zeros();
    for _ in 0..50 {
        let f = load_static_force(s, p);
        if f.norm() < 1e-11 {
            break;
        }
        let mut jac = Matrix3::zeros();
        let eps = 1e-6;
        for j in 0..3 {
            let mut dp = Vector3::zeros();
            dp[j] = eps;
            let col =
                (load_static_force(s, p + dp) - load_static_force(s, p - dp)) / (2.0 * eps);
            jac.set_column(j, &col);
        }
        match jac.lu().solve(&f) {
            Some(step) => p -= step,
            None => panic!("singular Jacobian"),
        }
    }
    p
}

fn finite_state(p: &Plant) -> bool {
    p.uavs
        .iter()
        .all(|u| finite3(&u.pos_m) && finite3(&u.vel_mps) && finite3(&u.thrust_n))
        && finite3(&p.load.pos_m)
        && finite3(&p.load.vel_mps)
}

fn max_speed_mps(p: &Plant) -> f64 {
    p.uavs
        .iter()
        .map(|u| u.vel_mps.norm())
        .fold(p.load.vel_mps.norm(), f64::max)
}

/// Energy of the modified Hamiltonian that semi-implicit Euler (kick, then drift) conserves
/// to O(h^2) for smooth conservative forces: `E + (h/2) sum v . F_cons`, with `F_cons`
/// gravity and the undamped, uncapped elastic cable force. (Check on `x'' = -w^2 x`: the
/// scheme conserves `v^2 + w^2 x^2 - h w^2 x v` exactly.) The true energy `E` instead
/// oscillates by O(h) and drifts by `-g^2 h^2 / 2` per kg per step in free fall.
fn shadow_energy_j(p: &Plant, h: f64) -> f64 {
    let g = gravity_vec_mps2();
    let mut power_w = 0.0;
    let mut f_load = p.load_params.mass_kg * g;
    for ((u, par), c) in p.uavs.iter().zip(&p.uav_params).zip(&p.cables) {
        let elastic = CableParams {
            damping_ns_per_m: 0.0,
            f_max_n: f64::INFINITY,
            ..*c
        };
        let f = cable_force(u.pos_m, u.vel_mps, p.load.pos_m, p.load.vel_mps, &elastic);
        power_w += u.vel_mps.dot(&(par.mass_kg * g + f.on_uav_n));
        f_load += f.on_load_n;
    }
    power_w += p.load.vel_mps.dot(&f_load);
    p.mechanical_energy_j() + 0.5 * h * power_w
}

/// Hanging configuration released 5 cm below equilibrium, UAVs given a horizontal spin of
/// `spin_rad_s` about the vertical axis through the load so the cables stay mostly taut,
/// zero thrust (the whole system falls freely).
fn free_falling_spinning(b: f64, spin_rad_s: f64) -> Plant {
    let s = setup(3, K_N_PER_M, b, f64::INFINITY, 0.0);
    let eq = load_equilibrium(&s);
    let mut p = plant(&s, eq - Vector3::new(0.0, 0.0, 0.05), 1);
    for u in &mut p.uavs {
        let r = Vector3::new(u.pos_m.x, u.pos_m.y, 0.0);
        u.vel_mps = Vector3::new(0.0, 0.0, spin_rad_s).cross(&r);
    }
    p
}

fn hanging_load_settles(n: usize) {
    let s = setup(n, K_N_PER_M, B_NS_PER_M, f64::INFINITY, 0.0);
    let eq = load_equilibrium(&s);
    assert!(load_static_force(&s, eq).norm() < 1e-9);
    let mut p = plant(&s, eq - Vector3::new(0.0, 0.0, 0.1), 1);
    assert!(
        p.tensions_n().iter().all(|t| *t > 0.0),
        "cables must start taut"
    );
    for _ in 0..20_000 {
        // Ideal hover recomputed each step: with one sub-step the UAVs' net force is zero,
        // so they stay pinned.
        let cmd = p.hover_thrust();
        p.step(&cmd, &[], Vector3::zeros(), DT_S);
    }
    assert!(finite_state(&p));
    for (u, q) in p.uavs.iter().zip(&s.uav_pos) {
        assert!(
            (u.pos_m - q).norm() < 1e-9,
            "UAV moved: {}",
            (u.pos_m - q).norm()
        );
    }
    let speed = p.load.vel_mps.norm();
    let err = (p.load.pos_m - eq).norm();
    assert!(speed < 1e-3, "load speed {speed} m/s after 20 s");
    assert!(err < 1e-3, "load {err} m from the static equilibrium");
    assert!(p.tensions_n().iter().all(|t| *t > 0.0));
}

#[test]
fn hanging_load_settles_at_static_equilibrium_3_uavs() {
    hanging_load_settles(3);
}

#[test]
fn hanging_load_settles_at_static_equilibrium_10_uavs() {
    hanging_load_settles(10);
}

#[test]
fn hover_thrust_at_equilibrium_keeps_everything_at_rest() {
    let s = setup(10, K_N_PER_M, B_NS_PER_M, f64::INFINITY, 0.0);
    let mut p = plant(&s, load_equilibrium(&s), 1);
    let cmd = p.hover_thrust();
    // Total hover thrust carries everything: sum = total weight, upwards.
    let total: Vector3<f64> = cmd.iter().sum();
    let weight_n = (10.0 * UAV_MASS_KG + LOAD_MASS_KG) * GRAVITY_MPS2;
    assert!((total - Vector3::new(0.0, 0.0, weight_n)).norm() < 1e-6);
    for _ in 0..1000 {
        p.step(&cmd, &[], Vector3::zeros(), DT_S);
    }
    assert!(max_speed_mps(&p) < 1e-6, "speed {}", max_speed_mps(&p));
}

#[test]
fn undamped_free_fall_energy_does_not_grow() {
    let mut p = free_falling_spinning(0.0, 2.0);
    let zero = vec![Vector3::zeros(); 3];
    let e0 = p.mechanical_energy_j();
    let s0 = shadow_energy_j(&p, DT_S);
    let mut max_shadow_drift_j: f64 = 0.0;
    for _ in 0..10_000 {
        p.step(&zero, &[], Vector3::zeros(), DT_S);
        let e = p.mechanical_energy_j();
        // E never exceeds its start (1e-9 relative slack for round-off).
        assert!(e <= e0 + 1e-9 * e0.abs(), "energy grew: {e} > {e0}");
        max_shadow_drift_j = max_shadow_drift_j.max((shadow_energy_j(&p, DT_S) - s0).abs());
    }
    assert!(finite_state(&p));
    // What the integrator does conserve, to O(h^2) (the one-sided cable's kink at the rest
    // length costs a little at each slack/taut transition): drift < 1e-2 J over 10 s for an
    // internal elastic + kinetic energy of tens of J.
    assert!(
        max_shadow_drift_j < 1e-2,
        "shadow energy drift {max_shadow_drift_j} J"
    );
    // The true energy falls only by the scheme's known gravity bias, -g^2 h^2/2 per kg per step.
    let bias_j = 0.5 * GRAVITY_MPS2 * GRAVITY_MPS2 * DT_S * DT_S * 24.0 * 10_000.0;
    let e = p.mechanical_energy_j();
    assert!(
        (e0 - e - bias_j).abs() < 1e-1,
        "E fell {} J, bias {bias_j} J",
        e0 - e
    );
}

#[test]
fn damped_energy_is_non_increasing_step_to_step() {
    for spin in [0.0, 2.0, 3.0] {
        let mut p = free_falling_spinning(B_NS_PER_M, spin);
        let zero = vec![Vector3::zeros(); 3];
        let mut e_prev = p.mechanical_energy_j();
        let mut s_prev = shadow_energy_j(&p, DT_S);
        let s0 = s_prev;
        for _ in 0..10_000 {
            p.step(&zero, &[], Vector3::zeros(), DT_S);
            let e = p.mechanical_energy_j();
            assert!(
                e <= e_prev + 1e-9 * e_prev.abs(),
                "spin {spin}: E rose {e_prev} -> {e}"
            );
            // The modified energy too, with an O(h^2) allowance (observed <= 1e-6 J).
            let sh = shadow_energy_j(&p, DT_S);
            assert!(
                sh <= s_prev + 1e-5,
                "spin {spin}: shadow rose {s_prev} -> {sh}"
            );
            e_prev = e;
            s_prev = sh;
        }
        assert!(
            s_prev < s0 - 1.0,
            "spin {spin}: damping dissipated too little"
        );
    }
}

#[test]
fn cable_forces_conserve_total_momentum() {
    let mut p = free_falling_spinning(B_NS_PER_M, 2.0);
    let momentum = |p: &Plant| -> Vector3<f64> {
        p.uavs
            .iter()
            .zip(&p.uav_params)
            .map(|(u, q)| q.mass_kg * u.vel_mps)
            .sum::<Vector3<f64>>()
            + p.load_params.mass_kg * p.load.vel_mps
    };
    let m0 = momentum(&p);
    let zero = vec![Vector3::zeros(); 3];
    for _ in 0..1000 {
        p.step(&zero, &[], Vector3::zeros(), DT_S);
    }
    let expected = m0 + 24.0 * gravity_vec_mps2() * 1.0;
    assert!(
        (momentum(&p) - expected).norm() < 1e-9,
        "{}",
        (momentum(&p) - expected).norm()
    );
}

#[test]
fn stiff_cables_with_substeps_stay_bounded() {
    let k = 5000.0;
    let s = setup(3, k, B_NS_PER_M, f64::INFINITY, 0.0);
    let eq = load_equilibrium(&s);
    // Hover thrust for the equilibrium, held constant: the UAVs are free to move.
    let cmd = plant(&s, eq, 1).hover_thrust();
    let mut p = plant(&s, eq - Vector3::new(0.0, 0.0, 0.05), 4);
    let start: Vec<Vector3<f64>> = p.uavs.iter().map(|u| u.pos_m).collect();
    for _ in 0..10_000 {
        p.step(&cmd, &[], Vector3::zeros(), DT_S);
        assert!(finite_state(&p));
        assert!(max_speed_mps(&p) < 5.0);
    }
    for (u, q) in p.uavs.iter().zip(&start) {
        assert!((u.pos_m - q).norm() < 0.5);
    }
    assert!((p.load.pos_m - eq).norm() < 0.5);
    assert!(p.tensions_n().iter().all(|t| t.is_finite() && *t >= 0.0));
}

#[test]
fn substeps_equal_repeated_shorter_steps() {
    let s = setup(3, K_N_PER_M, B_NS_PER_M, 80.0, 0.05);
    let eq = load_equilibrium(&s);
    let cmd: Vec<Vector3<f64>> = plant(&s, eq, 1)
        .hover_thrust()
        .iter()
        .map(|t| t * 1.02)
        .collect();
    let wind = [Vector3::new(1.0, -2.0, 0.0); 3];
    let mut a = plant(&s, eq - Vector3::new(0.0, 0.0, 0.1), 4);
    let mut b = plant(&s, eq - Vector3::new(0.0, 0.0, 0.1), 1);
    for _ in 0..500 {
        a.step(&cmd, &wind, Vector3::new(0.5, 0.0, 0.0), DT_S);
        for _ in 0..4 {
            b.step(&cmd, &wind, Vector3::new(0.5, 0.0, 0.0), DT_S / 4.0);
        }
    }
    for (ua, ub) in a.uavs.iter().zip(&b.uavs) {
        assert!((ua.pos_m - ub.pos_m).norm() < 1e-9);
        assert!((ua.vel_mps - ub.vel_mps).norm() < 1e-9);
        assert!((ua.thrust_n - ub.thrust_n).norm() < 1e-9);
    }
    assert!((a.load.pos_m - b.load.pos_m).norm() < 1e-9);
    for (ta, tb) in a.tensions_n().iter().zip(b.tensions_n()) {
        assert!((ta - tb).abs() < 1e-6);
    }
}

fn single_uav(thrust_max_n: f64, lag_s: f64) -> Plant {
    // Slack cable: rest length 10 m, UAV 1 m above the load.
    let uav = UavParams {
        mass_kg: UAV_MASS_KG,
        thrust_max_n,
        thrust_lag_s: lag_s,
    };
    let cable = CableParams {
        rest_length_m: 10.0,
        stiffness_n_per_m: K_N_PER_M,
        damping_ns_per_m: B_NS_PER_M,
        f_max_n: f64::INFINITY,
    };
    match Plant::new(
        vec![uav],
        vec![cable],
        LoadParams {
            mass_kg: LOAD_MASS_KG,
        },
        &[Vector3::new(0.0, 0.0, 1.0)],
        Vector3::zeros(),
        2,
    ) {
        Ok(p) => p,
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn thrust_command_is_limited_to_thrust_max() {
    let mut p = single_uav(50.0, 0.0);
    let dir = Vector3::new(1.0, 2.0, 3.0).normalize();
    p.step(&[dir * 1e6], &[], Vector3::zeros(), DT_S);
    assert!((p.uavs[0].thrust_n - dir * 50.0).norm() < 1e-12);
    // Acceleration from the limited thrust, not the command (cable slack).
    let a = p.uavs[0].vel_mps / DT_S;
    let expected = dir * 50.0 / UAV_MASS_KG + gravity_vec_mps2();
    assert!((a - expected).norm() < 1e-9);
    // Overflowing-norm command is still limited, direction kept.
    p.step(
        &[Vector3::new(1e300, 0.0, 1e300)],
        &[],
        Vector3::zeros(),
        DT_S,
    );
    let t = p.uavs[0].thrust_n;
    assert!((t.norm() - 50.0).abs() < 1e-9 && (t.x - t.z).abs() < 1e-9);
}

#[test]
fn thrust_lag_follows_exact_first_order_response() {
    let tau = 0.05;
    let mut p = single_uav(100.0, tau);
    let cmd = Vector3::new(0.0, 0.0, 30.0);
    for _ in 0..100 {
        p.step(&[cmd], &[], Vector3::zeros(), DT_S);
    }
    let expected = 30.0 * (1.0 - (-0.1_f64 / tau).exp());
    assert!((p.uavs[0].thrust_n.z - expected).abs() < 1e-9);
}

#[test]
fn non_finite_thrust_command_holds_previous_thrust_and_state_stays_finite() {
    let mut p = single_uav(50.0, 0.02);
    let cmd = Vector3::new(0.0, 0.0, 25.0);
    p.step(&[cmd], &[], Vector3::zeros(), DT_S);
    let held = p.uavs[0].thrust_n;
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        p.step(&[Vector3::new(0.0, bad, 1.0)], &[], Vector3::zeros(), DT_S);
        assert_eq!(p.uavs[0].thrust_n, held);
        assert!(finite_state(&p));
    }
    // Missing command, non-finite external forces, bad dt: defined and finite.
    p.step(
        &[],
        &[Vector3::new(f64::NAN, 0.0, 0.0)],
        Vector3::new(0.0, f64::INFINITY, 0.0),
        DT_S,
    );
    assert_eq!(p.uavs[0].thrust_n, held);
    assert!(finite_state(&p));
    let before = p.clone();
    for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        p.step(&[cmd], &[], Vector3::zeros(), dt);
    }
    assert_eq!(p.uavs, before.uavs);
    assert_eq!(p.load, before.load);
}

#[test]
fn external_forces_act_on_the_right_bodies() {
    let mut p = single_uav(50.0, 0.0);
    let f_uav = Vector3::new(4.0, 0.0, 0.0);
    let f_load = Vector3::new(0.0, 9.0, 0.0);
    p.step(&[Vector3::zeros()], &[f_uav], f_load, DT_S);
    let a_uav = p.uavs[0].vel_mps / DT_S;
    let a_load = p.load.vel_mps / DT_S;
    assert!((a_uav - (f_uav / UAV_MASS_KG + gravity_vec_mps2())).norm() < 1e-9);
    assert!((a_load - (f_load / LOAD_MASS_KG + gravity_vec_mps2())).norm() < 1e-9);
}

#[test]
fn tensions_are_those_of_the_last_substep() {
    let s = setup(3, K_N_PER_M, B_NS_PER_M, 20.0, 0.0);
    let mut p = plant(&s, load_equilibrium(&s), 3);
    let cmd = p.hover_thrust();
    p.step(&cmd, &[], Vector3::zeros(), DT_S);
    assert_eq!(p.tensions_n().len(), 3);
    for (t, f) in p.tensions_n().iter().zip(p.last_cable_forces()) {
        assert_eq!(*t, f.tension_n);
        assert!(*t >= 0.0 && *t <= 20.0);
    }
}

#[test]
fn new_rejects_invalid_input_and_names_it() {
    let s = setup(3, K_N_PER_M, B_NS_PER_M, 20.0, 0.0);
    let try_new = |u: Vec<UavParams>,
                   c: Vec<CableParams>,
                   l: LoadParams,
                   pos: &[Vector3<f64>],
                   lp: Vector3<f64>,
                   n: usize| { Plant::new(u, c, l, pos, lp, n).err() };
    let z = Vector3::zeros();
    assert_eq!(
        try_new(
            s.uavs.clone(),
            s.cables[..2].to_vec(),
            s.load,
            &s.uav_pos,
            z,
            1
        ),
        Some(PlantError::CountMismatch {
            uavs: 3,
            cables: 2,
            positions: 3
        })
    );
    let mut u = s.uavs.clone();
    u[1].mass_kg = 0.0;
    assert_eq!(
        try_new(u, s.cables.clone(), s.load, &s.uav_pos, z, 1),
        Some(PlantError::UavMass { index: 1 })
    );
    let mut u = s.uavs.clone();
    u[2].thrust_max_n = f64::NAN;
    assert_eq!(
        try_new(u, s.cables.clone(), s.load, &s.uav_pos, z, 1),
        Some(PlantError::UavThrustMax { index: 2 })
    );
    let mut u = s.uavs.clone();
    u[0].thrust_lag_s = -0.1;
    assert_eq!(
        try_new(u, s.cables.clone(), s.load, &s.uav_pos, z, 1),
        Some(PlantError::UavThrustLag { index: 0 })
    );
    assert_eq!(
        try_new(
            s.uavs.clone(),
            s.cables.clone(),
            LoadParams {
                mass_kg: f64::INFINITY
            },
            &s.uav_pos,
            z,
            1
        ),
        Some(PlantError::LoadMass)
    );
    let mut c = s.cables.clone();
    c[1].stiffness_n_per_m = f64::NAN;
    assert_eq!(
        try_new(s.uavs.clone(), c, s.load, &s.uav_pos, z, 1),
        Some(PlantError::Cable { index: 1 })
    );
    let mut pos = s.uav_pos.clone();
    pos[2].y = f64::NAN;
    assert_eq!(
        try_new(s.uavs.clone(), s.cables.clone(), s.load, &pos, z, 1),
        Some(PlantError::UavPosition { index: 2 })
    );
    assert_eq!(
        try_new(
            s.uavs.clone(),
            s.cables.clone(),
            s.load,
            &s.uav_pos,
            Vector3::new(f64::NAN, 0.0, 0.0),
            1
        ),
        Some(PlantError::LoadPosition)
    );
    let err = try_new(s.uavs.clone(), s.cables.clone(), s.load, &s.uav_pos, z, 0);
    assert_eq!(err, Some(PlantError::ZeroSubsteps));
    assert!(PlantError::ZeroSubsteps.to_string().contains("substeps"));
    assert!(PlantError::UavMass { index: 1 }
        .to_string()
        .contains("UAV 1"));
    // Unlimited thrust and cable cap are accepted.
    let mut u = s.uavs.clone();
    u[0].thrust_max_n = f64::INFINITY;
    let mut c = s.cables.clone();
    c[0].f_max_n = f64::INFINITY;
    assert_eq!(try_new(u, c, s.load, &s.uav_pos, z, 1), None);
}

/// Three UAVs hovering with slack cables above a load resting at `rest_z` (1 m below them,
/// well inside every cable's length), the load given `vel` (m/s) and lifted `lift_m` above
/// its rest.
fn resting_load(vel: Vector3<f64>, lift_m: f64) -> (Plant, f64) {
    let s = setup(3, 500.0, 5.0, f64::INFINITY, 0.0);
    let rest_z = s.uav_pos[0].z - 1.0;
    let mut p = plant(&s, Vector3::new(0.0, 0.0, rest_z + lift_m), 1);
    p.set_load_rest_z(rest_z);
    p.load.vel_mps = vel;
    (p, rest_z)
}

fn step_on_ground(p: &mut Plant, dt: f64) -> Option<f64> {
    let hover = p.hover_thrust();
    let zeros = vec![Vector3::zeros(); p.n_uavs()];
    p.step(&hover, &zeros, Vector3::zeros(), dt);
    p.ground_contact()
}

/// A load sliding on the ground decelerates at `mu g` (Coulomb friction), stops, and stays
/// stopped; it never goes below its resting altitude and never leaves it.
#[test]
fn a_sliding_load_decelerates_at_mu_g_and_stops() {
    let (mut p, rest_z) = resting_load(Vector3::new(2.0, 0.0, 0.0), 0.0);
    let dt = 0.001;
    for _ in 0..200 {
        step_on_ground(&mut p, dt);
        assert!((p.load.pos_m.z - rest_z).abs() < 1e-12, "no penetration, no hop");
    }
    let expected = 2.0 - GROUND_FRICTION * GRAVITY_MPS2 * 0.2;
    assert!((p.load.vel_mps.x - expected).abs() < 0.02, "speed {} after 0.2 s, expected {expected}", p.load.vel_mps.x);
    for _ in 0..1000 {
        step_on_ground(&mut p, dt);
    }
    assert!(p.load.vel_mps.norm() < 1e-9, "stopped: {:?}", p.load.vel_mps);
    let x = p.load.pos_m.x;
    for _ in 0..1000 {
        step_on_ground(&mut p, dt);
    }
    assert!((p.load.pos_m.x - x).abs() < 1e-9, "no creep at rest");
}

/// A dropped load meets the ground at `sqrt(2 g h)` and does not bounce: the contact is
/// perfectly inelastic and reports the impact speed.
#[test]
fn a_dropped_load_lands_without_bouncing() {
    let (mut p, rest_z) = resting_load(Vector3::zeros(), 0.5);
    let dt = 0.0005;
    let mut impact = None;
    for _ in 0..2000 {
        if let Some(v) = step_on_ground(&mut p, dt) {
            impact.get_or_insert(v);
        }
    }
    let v = impact.expect("the load hit the ground");
    let expected = (2.0 * GRAVITY_MPS2 * 0.5).sqrt();
    assert!((v - expected).abs() < 0.05, "impact {v} m/s, expected {expected}");
    assert!((p.load.pos_m.z - rest_z).abs() < 1e-12 && p.load.vel_mps.z.abs() < 1e-12, "at rest on the ground, no bounce");
}

/// Near the ground the wind falls off along MIL-F-8785C's log law (`shear_factor`): a body at
/// 20 ft or above meets the whole wind, the load resting 0.16 m up a quarter of it, and a
/// turbulent gust comes on top unscaled; with roughness 0 (the plant's default) every height
/// meets the whole wind.
#[test]
fn the_wind_falls_off_near_the_ground() {
    let s = setup(3, K_N_PER_M, B_NS_PER_M, f64::INFINITY, 0.0);
    let mut p = plant(&s, Vector3::zeros(), 1);
    let w = Vector3::new(9.0, 0.0, 0.0);
    assert_eq!(p.body_wind(&w, 10.0, 0), w);
    assert_eq!(p.body_wind(&w, 0.16, 3), w);
    let z0 = 0.15 * 0.3048;
    p.set_surface_roughness(z0);
    assert_eq!(p.body_wind(&w, crate::disturbance::WIND_REFERENCE_HEIGHT_M, 0), w);
    assert_eq!(p.body_wind(&w, 15.0, 0), w);
    let by_hand = 9.0 * (0.16_f64 / z0).ln() / (6.096_f64 / z0).ln();
    assert!((by_hand - 2.304).abs() < 1e-3, "{by_hand}");
    assert!((p.body_wind(&w, 0.16, 3) - Vector3::new(by_hand, 0.0, 0.0)).norm() < 1e-12);
    assert_eq!(p.body_wind(&w, 0.0, 0), Vector3::zeros(), "a landed UAV is out of the wind");
    let gust = Vector3::new(0.0, 1.0, 0.5);
    p.set_gusts(&[Vector3::zeros(), Vector3::zeros(), Vector3::zeros(), gust]);
    assert!((p.body_wind(&w, 0.16, 3) - Vector3::new(by_hand, 1.0, 0.5)).norm() < 1e-12);
}

/// A light crate on the ground (3 kg, drag area 0.3 m^2, friction 0.5: it holds 14.7 N) in a
/// 12 m/s wind: the uniform wind (26 N of drag) slides it away, the wind near the ground (a
/// quarter of it, 1.7 N) leaves it where it is. A UAV landed beside it, rotors off, its
/// cable slack.
#[test]
fn a_crate_on_the_ground_stays_in_the_wind_near_the_ground() {
    let slide = |roughness_m: f64| {
        let uav = UavParams { mass_kg: UAV_MASS_KG, thrust_max_n: 50.0, thrust_lag_s: 0.0 };
        let cable = CableParams { rest_length_m: 3.0, stiffness_n_per_m: K_N_PER_M, damping_ns_per_m: B_NS_PER_M, f_max_n: f64::INFINITY };
        let rest_z = 0.16;
        let mut p = match Plant::new(vec![uav], vec![cable], LoadParams { mass_kg: 3.0 }, &[Vector3::new(1.0, 0.0, 0.0)], Vector3::new(0.0, 0.0, rest_z), 1) {
            Ok(p) => p,
            Err(e) => panic!("setup rejected: {e}"),
        };
        p.set_load_rest_z(rest_z);
        p.set_surface_roughness(roughness_m);
        let off = [Setpoint { q_ned: [1.0, 0.0, 0.0, 0.0], thrust: 0.0 }];
        for _ in 0..1000 {
            p.step_setpoints(&off, &[true], &Vector3::new(12.0, 0.0, 0.0), 0.05, 0.3, DT_S);
            p.ground_contact();
        }
        p.load.pos_m.x
    };
    let uniform = slide(0.0);
    let sheared = slide(0.15 * 0.3048);
    assert!(uniform > 1.0, "the uniform wind slides the crate: {uniform} m in 1 s");
    // Friction acts after each step's integration: the crate creeps by `a dt^2` a step (0.6 mm in 1 s).
    assert!(sheared.abs() < 1e-3, "the wind near the ground does not: {sheared} m");
}
