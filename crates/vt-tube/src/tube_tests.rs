//! Tests of `tube` (kept apart to keep the table's file short).

use super::*;
use approx::assert_relative_eq;
use proptest::prelude::*;

type T = Tube<256>;

fn straight(w_left: f32, w_right: f32) -> T {
    T::from_waypoints(&[Waypoint::new(0.0, 0.0, w_left, w_right), Waypoint::new(20.0, 0.0, w_left, w_right)])
        .unwrap()
}

#[test]
fn rebuild_in_used_storage_matches_from_waypoints() {
    let wps = arc(15.0, 1.5, 2.0, 5);
    let fresh = T::from_waypoints(&wps).unwrap();
    let mut reused = straight(3.0, 1.0);
    reused.rebuild(&wps).unwrap();
    assert_eq!(reused.samples(), fresh.samples());
    assert_eq!(reused.certify_m, fresh.certify_m);
    assert_eq!((reused.chunk_center_m, reused.chunk_radius_m), (fresh.chunk_center_m, fresh.chunk_radius_m));
    assert_eq!((reused.length_m(), reused.ds_m()), (fresh.length_m(), fresh.ds_m()));
    let mut bad = T::placeholder();
    assert!(bad.rebuild(&wps[..1]).is_err());
}

/// Waypoints on a circle arc of radius `r` from angle 0 to `sweep` rad, centre at origin.
fn arc(r: f32, sweep: f32, w: f32, n: usize) -> Vec<Waypoint> {
    (0..n)
        .map(|i| {
            let a = sweep * i as f32 / (n - 1) as f32;
            Waypoint::new(r * a.cos(), r * a.sin(), w, w)
        })
        .collect()
}

/// An S-shaped tube like the paper's: 60 m, wide ends, narrow middle.
fn s_tube() -> T {
    T::from_waypoints(&[
        Waypoint::new(0.0, 0.0, 6.0, 6.0),
        Waypoint::new(12.0, 4.0, 5.0, 5.0),
        Waypoint::new(24.0, 0.0, 2.2, 2.2),
        Waypoint::new(36.0, -4.0, 2.2, 2.6),
        Waypoint::new(48.0, 0.0, 5.0, 5.0),
        Waypoint::new(60.0, 2.0, 6.0, 6.0),
    ])
    .unwrap()
}

#[test]
fn straight_tube_geometry_by_hand() {
    let tube = straight(3.0, 1.0);
    assert_relative_eq!(tube.length_m(), 20.0, epsilon = 1e-3);
    let sec = tube.locate(Vec2::new(7.0, 1.5), 0).unwrap();
    assert_relative_eq!(sec.s_m, 7.0, epsilon = 1e-3);
    assert_relative_eq!(sec.remaining_m, 13.0, epsilon = 1e-3);
    assert_relative_eq!(sec.tangent, Vec2::new(1.0, 0.0), epsilon = 1e-5);
    assert_relative_eq!(sec.normal, Vec2::new(0.0, 1.0), epsilon = 1e-5);
    assert_relative_eq!(sec.curvature_pm, 0.0, epsilon = 1e-5);
    // r_t = (3 + 1)/2 = 2; m = gamma + (3 - 1)/2 n = (7, 1).
    assert_relative_eq!(sec.half_width_m, 2.0, epsilon = 1e-5);
    assert_relative_eq!(sec.midpoint_m, Vec2::new(7.0, 1.0), epsilon = 1e-4);
    // d_t = 2 - |(7,1.5) - (7,1)| = 1.5.
    assert_relative_eq!(sec.boundary_distance_m(Vec2::new(7.0, 1.5)), 1.5, epsilon = 1e-4);
    assert_relative_eq!(sec.lateral_offset_m(Vec2::new(7.0, 1.5)), 1.5, epsilon = 1e-4);
}

#[test]
fn arc_tube_has_curvature_one_over_radius() {
    let tube = T::from_waypoints(&arc(10.0, 1.5, 2.0, 12)).unwrap();
    assert_relative_eq!(tube.length_m(), 15.0, epsilon = 0.05);
    // Interior of a natural spline through a circle: curvature ~ 1/10, left turn (+).
    let sec = tube.locate(Vec2::new(10.0 * 0.75f32.cos(), 10.0 * 0.75f32.sin()), 0).unwrap();
    assert_relative_eq!(sec.curvature_pm, 0.1, epsilon = 5e-3);
    assert_relative_eq!(sec.s_m, 7.5, epsilon = 0.05);
    // The normal points to the centre of a left turn.
    let to_center = -sec.point_m.normalize();
    assert!(sec.normal.dot(&to_center) > 0.999);
}

#[test]
fn points_beyond_the_ends_clamp_to_terminals() {
    let tube = straight(1.0, 1.0);
    let before = tube.locate(Vec2::new(-5.0, 0.3), 100).unwrap();
    assert_relative_eq!(before.s_m, 0.0);
    assert_relative_eq!(before.remaining_m, 20.0, epsilon = 1e-3);
    let after = tube.locate(Vec2::new(30.0, 0.0), 0).unwrap();
    assert_relative_eq!(after.s_m, tube.length_m());
    assert_eq!(after.remaining_m, 0.0);
}

#[test]
fn non_finite_point_has_no_section() {
    let tube = straight(1.0, 1.0);
    assert!(tube.locate(Vec2::new(f32::NAN, 0.0), 0).is_none());
    assert!(tube.locate(Vec2::new(0.0, f32::INFINITY), 0).is_none());
}

#[test]
fn folding_tube_is_rejected() {
    // Radius 3 m bend with 3.5 m half-width: w |kappa| > 1.
    let err = T::from_waypoints(&arc(3.0, 2.0, 3.5, 10)).unwrap_err();
    assert!(matches!(err, TubeError::Folding { ratio, .. } if ratio >= 1.0), "{err:?}");
}

#[test]
fn overlapping_terminals_are_rejected() {
    // A loop that comes back down through the start: the end section (horizontal, at
    // y = 0.5) crosses the start section (vertical, at x = 0).
    let wps = [
        Waypoint::new(0.0, 0.0, 2.0, 2.0),
        Waypoint::new(15.0, 0.0, 2.0, 2.0),
        Waypoint::new(22.0, 12.0, 2.0, 2.0),
        Waypoint::new(10.0, 22.0, 2.0, 2.0),
        Waypoint::new(-1.0, 12.0, 2.0, 2.0),
        Waypoint::new(-1.0, 0.5, 2.0, 2.0),
    ];
    let err = T::from_waypoints(&wps).unwrap_err();
    assert!(
        matches!(err, TubeError::OverlappingTerminals | TubeError::SelfOverlap { .. }),
        "{err:?}"
    );
}

#[test]
fn nearly_closed_annulus_is_valid() {
    // 355 deg of a 10 m circle, 2 m half-width: sections are radial and never meet.
    assert!(T::from_waypoints(&arc(10.0, 6.2, 2.0, 24)).is_ok());
}

#[test]
fn segment_intersection_by_hand() {
    let v = Vec2::new;
    assert!(segments_intersect(v(0.0, -1.0), v(0.0, 1.0), v(-1.0, 0.0), v(1.0, 0.0)));
    assert!(!segments_intersect(v(0.0, -1.0), v(0.0, 1.0), v(0.5, 0.0), v(1.0, 0.0)));
}

#[test]
fn self_overlapping_tube_is_rejected() {
    // A hairpin whose two legs are 4 m apart with 3 m half-widths: the legs overlap.
    let wps = [
        Waypoint::new(0.0, 0.0, 3.0, 3.0),
        Waypoint::new(20.0, 0.0, 3.0, 3.0),
        Waypoint::new(26.0, 2.0, 3.0, 3.0),
        Waypoint::new(20.0, 4.0, 3.0, 3.0),
        Waypoint::new(0.0, 4.0, 3.0, 3.0),
    ];
    assert!(T::from_waypoints(&wps).is_err());
}

#[test]
fn bad_waypoints_are_typed_errors() {
    assert_eq!(T::from_waypoints(&[]).unwrap_err(), TubeError::TooFewWaypoints);
    let nan = [Waypoint::new(0.0, 0.0, 1.0, 1.0), Waypoint::new(1.0, f32::NAN, 1.0, 1.0)];
    assert_eq!(T::from_waypoints(&nan).unwrap_err(), TubeError::NonFinite { index: 1 });
}

#[test]
fn samples_are_equally_spaced_in_arc_length() {
    let tube = s_tube();
    let ds = tube.ds_m();
    for w in tube.samples().windows(2) {
        let chord = (w[1].pos_m - w[0].pos_m).norm();
        assert!((chord - ds).abs() < 0.01 * ds, "chord {chord} vs ds {ds}");
    }
}

#[test]
fn warm_start_follows_a_trajectory() {
    let tube = s_tube();
    let mut hint = 0;
    for k in 0..600 {
        let s = k as f32 * 0.1;
        let smp = tube.samples()[((s / tube.ds_m()) as usize).min(255)];
        let q = smp.pos_m + smp.normal() * 1.0;
        let sec = tube.locate(q, hint).unwrap();
        let exact = tube.locate_exact(q);
        assert_relative_eq!(sec.s_m, exact.s_m, epsilon = 1e-4);
        hint = sec.segment;
    }
}

/// A hairpin: two long straight legs 12 m apart joined by a tight turn, so the local
/// certification radius is wide on the legs, bounded by the other leg, and small in the
/// turn. Every lookup on a dense grid and from every kind of hint equals the brute force.
#[test]
fn hairpin_lookups_equal_brute_force_and_most_are_certified() {
    let tube = T::from_waypoints(&[
        Waypoint::new(0.0, 0.0, 1.5, 1.5),
        Waypoint::new(30.0, 0.0, 1.5, 1.5),
        Waypoint::new(40.0, 6.0, 1.5, 1.5),
        Waypoint::new(30.0, 12.0, 1.5, 1.5),
        Waypoint::new(0.0, 12.0, 1.5, 1.5),
    ])
    .unwrap();
    let (mut checked, mut certified) = (0, 0);
    for ix in 0..120 {
        for iy in 0..60 {
            let q = Vec2::new(-5.0 + ix as f32 * 0.4, -6.0 + iy as f32 * 0.4);
            let exact = tube.locate_exact(q);
            let d_exact = (q - exact.point_m).norm();
            for hint in [0, exact.segment, exact.segment.saturating_sub(3), 128, 255] {
                let fast = tube.locate(q, hint).unwrap();
                let d_fast = (q - fast.point_m).norm();
                assert!((d_fast - d_exact).abs() < 1e-4, "q {q:?} hint {hint}: {d_fast} vs {d_exact}");
                checked += 1;
            }
            let k = exact.segment;
            let cert = tube.certify_m[k].min(tube.certify_m[(k + 1).min(255)]);
            certified += usize::from(d_exact < cert);
        }
    }
    // The pruned search of the table's own check is the exhaustive search, bit for bit, from
    // any seed (the lowest index among equal distances).
    for ix in 0..60 {
        for iy in 0..30 {
            let q = Vec2::new(-5.0 + ix as f32 * 0.8, -6.0 + iy as f32 * 0.8);
            let exact = tube.locate_exact(q);
            for seed in [0, 77, 254] {
                assert_eq!(tube.locate_pruned(q, seed), exact, "q {q:?} seed {seed}");
            }
        }
    }
    // The certification's far class by chunks is the exhaustive minimum, bit for bit.
    for t in [&tube, &s_tube()] {
        for k in 0..256usize {
            let pk = t.samples()[k].pos_m;
            let ranges = [k.checked_sub(65).map(|hi| (0, hi)), (k + 65 < 256).then(|| (k + 65, 255))];
            let brute = ranges.into_iter().flatten().flat_map(|(lo, hi)| lo..=hi).map(|j| (t.samples()[j].pos_m - pk).norm_squared()).fold(f32::MAX, f32::min);
            assert_eq!(t.closest_in_ranges2(pk, ranges).to_bits(), brute.to_bits(), "k {k}");
        }
    }
    // The legs certify out to about half their 12 m separation (global-curvature bound:
    // about 0.5 / kappa_max, under 2 m here).
    assert!(checked == 120 * 60 * 5);
    assert!(certified > 120 * 60 / 2, "certified {certified} of {}", 120 * 60);
}

#[test]
fn certified_radius_is_the_lookups_own_and_certifies_what_it_says() {
    let tube = s_tube();
    assert_eq!(tube.certified_radius_m(255), 0.0, "past the table");
    assert_eq!(tube.certified_radius_m(3), tube.certify_m[3].min(tube.certify_m[4]));
    assert!(straight(3.0, 1.0).certified_radius_m(100) > 2.0, "half the separation beyond a 64-sample window");
    // A point over a segment's middle, nearer to it than its certified radius, is located on
    // that segment from that hint, and that is the exhaustive search's segment.
    let mut checked = 0;
    for k in 0..255 {
        let (a, b) = (tube.samples()[k], tube.samples()[k + 1]);
        let mid = (a.pos_m + b.pos_m) * 0.5;
        let n = a.normal();
        let r = tube.certified_radius_m(k);
        for f in [-0.95f32, -0.5, 0.0, 0.5, 0.95] {
            let q = mid + n * (f * r);
            let sec = tube.locate(q, k).unwrap();
            assert_eq!(sec.segment, k, "segment {k}, offset {f} r");
            assert_eq!(sec.segment, tube.locate_exact(q).segment, "segment {k}, offset {f} r");
            checked += 1;
        }
    }
    assert_eq!(checked, 255 * 5);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn section_lookup_equals_brute_force(
        x in -10f32..70.0, y in -15f32..15.0, hint in 0usize..300,
    ) {
        let tube = s_tube();
        let q = Vec2::new(x, y);
        let fast = tube.locate(q, hint).unwrap();
        let exact = tube.locate_exact(q);
        let d_fast = (q - fast.point_m).norm();
        let d_exact = (q - exact.point_m).norm();
        prop_assert!((d_fast - d_exact).abs() < 1e-4, "fast {} vs exact {}", d_fast, d_exact);
    }

    #[test]
    fn lookup_on_random_tubes_equals_brute_force(
        ys in proptest::collection::vec(-6f32..6.0, 3..8),
        w in 0.5f32..2.0, qx in -5f32..80.0, qy in -12f32..12.0, hint in 0usize..256,
    ) {
        let wps: Vec<Waypoint> = ys.iter().enumerate()
            .map(|(i, y)| Waypoint::new(12.0 * i as f32, *y, w, w)).collect();
        if let Ok(tube) = T::from_waypoints(&wps) {
            let q = Vec2::new(qx, qy);
            let fast = tube.locate(q, hint).unwrap();
            let exact = tube.locate_exact(q);
            prop_assert!(((q - fast.point_m).norm() - (q - exact.point_m).norm()).abs() < 1e-4);
            prop_assert_eq!(tube.locate_pruned(q, hint.min(254)), exact);
        }
    }
}
