//! Tests of the companion's parameters (`params.rs`).

use super::*;

/// Issue 27: a body turns on the separation barrier at `2 VT_BODY_R + VT_CLR_MIN` and raises
/// the tube safety radius and the formation's separation floor to what it needs (the floor
/// plus `FORMATION_GUARD_M`); without one the controller is the paper's (barrier off, radii
/// as given).
#[test]
fn a_body_derives_the_separation_and_the_safety_radius() {
    let mut p = Params::default();
    assert_eq!((p.separation_m(), p.r_safe_m()), (0.0, 0.5));
    p.set(Param::BodyR, 0.445).unwrap();
    assert!((p.separation_m() - 1.09).abs() < 1e-6);
    assert!((p.r_safe_m() - 0.645).abs() < 1e-6);
    // The formation's floor: the barrier's plus the guard for where the UAVs fly.
    assert!((p.formation_separation_m() - 1.39).abs() < 1e-6);
    assert!((p.capacity().unwrap().separation_m - 1.39).abs() < 1e-6, "raised from VT_SEP_MIN 0.9");
    p.set(Param::RSafe, 0.8).unwrap();
    assert_eq!(p.r_safe_m(), 0.8, "a larger VT_R_SAFE is kept");
    let sep = p.separation_spec();
    assert_eq!((sep.pole_m, sep.band_m, sep.three_d), (p.separation_m(), vt_dissipative::separation::SEPARATION_BAND_M, false));
}

#[test]
fn the_shaped_formation_flies_the_contact_barrier() {
    let mut p = Params::default();
    assert!(p.shape().is_none(), "the paper's ring by default");
    p.set(Param::BodyR, 0.445).unwrap();
    p.set(Param::Shape, 1.0).unwrap();
    p.set(Param::ShapeMrg, 0.3).unwrap();
    assert_eq!(p.shape(), Some(ShapeParams { margin_m: 0.3, ahead_m: 6.0 }));
    // The contact barrier: its pole at the bodies' contact, its band the 0.2 m floor.
    let sep = p.separation_spec();
    let (pole, band) = (sep.pole_m, sep.band_m);
    assert!((pole - 0.89).abs() < 1e-6 && (band - 0.2).abs() < 1e-6 && sep.three_d, "{sep:?}");
    let cal = vt_dissipative::Calibration { cable_length_m: 8.0, stretch_m: 0.02, tension_share_n: 10.0, cos_lean: 0.95, distance_m: 8.02 };
    assert_eq!(p.dissipative(&cal).map(|d| d.separation), Ok(sep));
    assert!((p.separation_m() - 1.09).abs() < 1e-6, "the floor keeps the body's separation");
    assert!((p.capacity().unwrap().separation_m - 1.39).abs() < 1e-6, "and the formation its guard above it");
    assert!((p.r_safe_m() - 0.645).abs() < 1e-6, "and the tube barrier its radius");
}

#[test]
fn names_fit_mavlink_and_are_unique() {
    for (k, info) in TABLE.iter().enumerate() {
        assert!(info.name.len() <= 16, "{}", info.name);
        let auto = info.auto && info.default == AUTO;
        assert!(auto || (info.min <= info.default && info.default <= info.max), "{}", info.name);
        assert_eq!(Param::from_name(info.name).map(|p| p as usize), Some(k));
    }
    assert_eq!(ALL.len(), TABLE.len());
}

#[test]
fn defaults_build_valid_controllers() {
    let p = Params::new();
    // The experiment's take-off (3 UAVs, lean atan(1.5/4), 3 m cables) calibrates, passes
    // the pre-flight check and builds the controllers with the defaults.
    let load = crate::Vec3::new(0.0, 0.0, 3.0);
    let uavs: [crate::Vec3; 3] = core::array::from_fn(|i| {
        let a = i as f32 * 2.0944;
        load + crate::Vec3::new(1.5 * 0.75 * libm::cosf(a), 1.5 * 0.75 * libm::sinf(a), 3.0)
    });
    let cal = vt_dissipative::calibrate(0, &uavs, &load, &p.calibration()).unwrap();
    vt_dissipative::feasibility::check(&p.feasibility(cal.cos_lean)).unwrap();
    p.dissipative(&cal).unwrap();
    p.velocity_loop().unwrap();
    assert_eq!(p.capacity().unwrap().load_mass_kg, p.get(Param::LoadKg), "capacity law on with the declared load");
    let mut off = p.clone();
    off.set(Param::CapOn, 0.0).unwrap();
    assert_eq!(off.capacity().unwrap().load_mass_kg, 0.0, "VT_CAP_ON = 0: the paper's controller");
    assert_eq!(p.low_per_high(), Some(10));
    assert_eq!(p.own_system_id(), 1);
}

#[test]
fn bad_values_are_refused() {
    let mut p = Params::new();
    assert_eq!(p.set(Param::K1, f32::NAN), Err(ParamError::BadValue));
    assert_eq!(p.set(Param::NUavs, 2.5), Err(ParamError::BadValue));
    assert_eq!(p.set(Param::NUavs, crate::MAX_UAVS as f32 + 1.0), Err(ParamError::BadValue));
    assert_eq!(p.set(Param::NUavs, 10.0), Ok(()));
    assert_eq!(p.get_u32(Param::NUavs), 10);
}

#[test]
fn derived_values_follow_their_rules_and_explicit_values_win() {
    let mut p = Params::new();
    // Defaults: the experiment's airframe (1.47 kg, 30 N) on 3 m cables rated 30 N.
    assert_eq!(p.min_height_m(), 1.0);
    assert_eq!(p.max_cable_m(), 4.5);
    assert_eq!(p.thrust_min_n(), 1.5);
    // The declared 3.06 kg's share with the vertical cap's 15 % margin, 11.5 N, binds before
    // the 30 N rating: sqrt(1 - ((14.42 + 11.51) / 30)^2) = 0.504, so the cap.
    assert!((p.reserve_pull_n() - 1.15 * 3.06 * vt_cfo::GRAVITY_MPS2 / 3.0).abs() < 1e-5);
    assert_eq!(p.horizontal_reserve(), HORIZONTAL_RESERVE_CAP, "the declared share leaves room");
    // A formation margin above the vertical cap's wins.
    p.set(Param::CapMargin, 0.3).unwrap();
    assert!((p.reserve_pull_n() - 1.3 * 3.06 * vt_cfo::GRAVITY_MPS2 / 3.0).abs() < 1e-5);
    p.set(Param::CapMargin, 0.05).unwrap();
    // The 93 %-loaded light team of generated seed 5195 (6 UAVs, 6.51 kg): the cap keeps 15 %
    // over the share, sqrt(1 - ((14.42 + 1.15 x 10.64) / 30)^2) = 0.456 of the thrust for the
    // horizontal (0.486 with the 5 % alone).
    p.set(Param::LoadKg, 6.51).unwrap();
    p.set(Param::NUavs, 6.0).unwrap();
    let share = 6.51 * vt_cfo::GRAVITY_MPS2 / 6.0;
    let need = (1.47 * vt_cfo::GRAVITY_MPS2 + 1.15 * share) / 30.0;
    assert!((p.horizontal_reserve() - vt_fpu::sqrt(1.0 - need * need)).abs() < 1e-6, "{}", p.horizontal_reserve());
    assert!(p.horizontal_reserve() < HORIZONTAL_RESERVE_CAP);
    p.set(Param::NUavs, 3.0).unwrap();
    p.set(Param::LoadKg, 6.0).unwrap();
    assert_eq!(p.horizontal_reserve(), 0.0, "30 N cannot lift 1.47 kg + 21 N: no reserve");
    p.set(Param::LoadKg, 0.0).unwrap();
    assert_eq!(p.reserve_pull_n(), 30.0, "no declared load: the rating");
    assert_eq!(p.horizontal_reserve(), 0.0, "30 N cannot lift 1.47 kg + 30 N: no reserve");
    p.set(Param::LoadKg, 3.06).unwrap();
    assert_eq!(p.neighbour_timeout_ms(), 500);
    p.set(Param::CableL, 1.6).unwrap();
    assert_eq!(p.min_height_m(), 0.8, "half a short cable");
    p.set(Param::Lockstep, 1.0).unwrap();
    assert_eq!(p.neighbour_timeout_ms(), 10, "half of 1 / 50 Hz");
    p.set(Param::Mass, 2.0).unwrap();
    p.set(Param::ThrustMax, 50.0).unwrap();
    p.set(Param::CableRated, 20.0).unwrap();
    assert_eq!(p.horizontal_reserve(), HORIZONTAL_RESERVE_CAP, "the paper airframe affords the cap");
    assert_eq!(p.thrust_min_n(), 2.5);
    for (q, v) in [(Param::ZMin, 0.7), (Param::CableLMax, 9.0), (Param::ThrustMin, 3.0), (Param::HReserve, 0.2), (Param::FsNbrTmo, 0.25)] {
        p.set(q, v).unwrap();
    }
    assert_eq!((p.min_height_m(), p.max_cable_m(), p.thrust_min_n(), p.horizontal_reserve(), p.neighbour_timeout_ms()), (0.7, 9.0, 3.0, 0.2, 250));
    // -1 only where a rule exists; other negatives stay refused.
    assert_eq!(p.set(Param::ZMin, -0.5), Err(ParamError::BadValue));
    assert_eq!(p.set(Param::K1, AUTO), Err(ParamError::BadValue));
    assert_eq!(p.set(Param::ZMin, AUTO), Ok(()));
    assert_eq!(p.min_height_m(), 0.8);
}

#[test]
fn heading_is_unit_and_north_by_default() {
    let h = Params::new().heading();
    assert_eq!((h.x, h.y), (0.0, 1.0));
}
