//! Tests of `clearance` (kept apart to keep its file short).

use super::*;
use crate::map::Shape;

#[test]
fn clearances_subtract_the_envelopes() {
    let tube = SimTube::from_waypoints(&[vt_tube::Waypoint::new(0.0, 0.0, 3.0, 3.0), vt_tube::Waypoint::new(20.0, 0.0, 3.0, 3.0)]).unwrap();
    let obstacles = Obstacles::of_shapes(&[Shape::Circle { center_m: [10.0, 6.0], radius_m: 1.0 }]);
    let mut c = Clearances::new(3, 0.4, 0.3, obstacles);
    let uavs = [V3::new(10.0, 2.0, 8.0), V3::new(11.0, 2.0, 8.0), V3::new(5.0, 0.0, 8.0)];
    c.sample(&uavs, &V3::new(10.0, 0.0, 2.0), &[false, false, false], &[true, true, true], &tube);
    let m = c.min();
    assert!((m.uav_uav_m - 0.2).abs() < 1e-9, "{m:?}");
    assert!((m.uav_boundary_m - 0.6).abs() < 1e-5, "1 m from the boundary less 0.4: {m:?}");
    // UAV 0 at 4 m from the circle's centre: 3 m from its rim, 2.6 m from its body.
    assert!((m.obstacle_m - 2.6).abs() < 1e-9, "{m:?}");
    // A UAV that is down, and a cut cable, are left out.
    let mut c2 = Clearances::new(3, 0.4, 0.3, Obstacles::of_shapes(&[Shape::Circle { center_m: [10.0, 6.0], radius_m: 1.0 }]));
    c2.sample(&uavs, &V3::new(10.0, 0.0, 2.0), &[false, true, false], &[true, true, false], &tube);
    assert!(c2.min().uav_uav_m > 4.0);
}

#[test]
fn skipping_what_cannot_be_closer_gives_the_brute_force_minimum_bit_for_bit() {
    let bodies = vec![
        Shape::Circle { center_m: [10.0, 6.0], radius_m: 1.0 },
        Shape::Circle { center_m: [3.0, -4.0], radius_m: 0.5 },
        Shape::Wall { from_m: [15.0, -5.0], to_m: [18.0, 3.0], thickness_m: 0.3 },
        Shape::Polygon(vec![[5.0, 2.0], [7.0, 2.5], [6.0, 4.0]]),
    ];
    let tube = SimTube::from_waypoints(&[vt_tube::Waypoint::new(0.0, 0.0, 6.0, 6.0), vt_tube::Waypoint::new(20.0, 0.0, 6.0, 6.0)]).unwrap();
    let (r, rl) = (0.4, 0.3);
    let mut c = Clearances::new(4, r, rl, Obstacles::of_shapes(&bodies));
    let bodies: Vec<Obstacles> = bodies.iter().map(|b| Obstacles::of_shapes(std::slice::from_ref(b))).collect();
    let mut brute = f64::INFINITY;
    let mut brute_pair = f64::INFINITY;
    let mut seed = 12345_u64;
    let mut rnd = |lo: f64, hi: f64| {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((seed >> 11) as f64 / (1u64 << 53) as f64)
    };
    // Random walks (the skip's case: small moves between samples) with a jump every
    // 500 samples.
    let mut uavs: Vec<V3> = Vec::new();
    let mut load = V3::zeros();
    for k in 0..20_000 {
        if k % 500 == 0 {
            uavs = (0..4).map(|_| V3::new(rnd(0.0, 20.0), rnd(-6.0, 6.0), 8.0)).collect();
            load = V3::new(rnd(0.0, 20.0), rnd(-5.0, 5.0), 2.0);
        }
        for u in uavs.iter_mut().chain(std::iter::once(&mut load)) {
            *u += V3::new(rnd(-0.03, 0.03), rnd(-0.03, 0.03), 0.0);
        }
        c.sample(&uavs, &load, &[false; 4], &[true; 4], &tube);
        let (lx, ly) = (load.x, load.y);
        for u in &uavs {
            for b in &bodies {
                brute = brute.min(b.point_m(u.xy()) - r).min(b.segment_m(u.xy(), V2::new(lx, ly)));
            }
        }
        for b in &bodies {
            brute = brute.min(b.point_m(V2::new(lx, ly)) - rl);
        }
        for (i, p) in uavs.iter().enumerate() {
            for q in uavs.iter().skip(i + 1) {
                brute_pair = brute_pair.min((p - q).norm() - 2.0 * r);
            }
        }
        assert_eq!(c.min().obstacle_m.to_bits(), brute.to_bits());
        assert_eq!(c.min().uav_uav_m.to_bits(), brute_pair.to_bits());
    }
}

/// A tube through `[x, y, half-width left, half-width right]` waypoints (m).
fn tube_of(waypoints: &[[f32; 4]]) -> SimTube {
    let w: Vec<vt_tube::Waypoint> = waypoints.iter().map(|&[x, y, l, r]| vt_tube::Waypoint::new(x, y, l, r)).collect();
    SimTube::from_waypoints(&w).unwrap()
}

/// The paper's tube (scenarios/paper-10uav.toml): two narrow passages, the second asymmetric.
fn paper_tube() -> SimTube {
    tube_of(&[
        [2.0, 0.0, 5.5, 5.5],
        [9.0, 1.5, 5.5, 5.5],
        [16.0, 2.0, 2.4, 2.4],
        [23.0, 0.0, 5.0, 5.0],
        [30.0, -2.5, 2.1, 2.6],
        [37.0, -1.5, 5.0, 5.0],
        [43.0, 0.5, 5.5, 5.5],
        [48.0, 1.0, 5.5, 5.5],
    ])
}

/// A re-planned tube: tighter bends, a lopsided narrowing, a short table spacing.
fn bend_tube() -> SimTube {
    tube_of(&[[0.0, 0.0, 3.0, 3.0], [6.0, 3.0, 2.5, 2.0], [12.0, 0.5, 0.9, 1.8], [17.0, 4.0, 2.0, 2.0], [22.0, 2.0, 3.0, 2.5]])
}

/// A hairpin: two legs 9 m apart with 2 m between their boundaries, so beyond the certified
/// radius the other leg is near.
fn hairpin_tube() -> SimTube {
    tube_of(&[
        [0.0, 0.0, 3.5, 3.5],
        [12.0, 0.0, 3.5, 3.0],
        [18.0, 0.3, 2.0, 2.0],
        [21.8, 2.2, 1.5, 1.5],
        [22.6, 4.5, 1.5, 1.5],
        [21.8, 6.8, 1.5, 1.5],
        [18.0, 8.7, 2.0, 2.0],
        [12.0, 9.0, 3.0, 3.5],
        [0.0, 9.0, 3.5, 3.5],
    ])
}

/// Random walks of ten UAVs in and near a tube, each sample measured both ways: `Clearances`
/// (anchors) and the brute force (a lookup for every UAV at every sample, as `sample` did).
/// The tube lives in one box and `swap(episode, k)` replaces it in place (the same address,
/// another tube). A UAV jumps now and then to `reach` m beyond the tube's boundary at most.
/// Asserts the minimum and every hint equal, bit for bit, at every sample; returns the lookups
/// made and the UAV samples.
fn walks_match_the_brute_force(seed: u64, episodes: usize, steps: usize, reach: f64, swap: impl Fn(usize, usize) -> Option<SimTube>) -> (usize, usize) {
    let n = 10;
    let r = 0.4;
    let mut seed = seed;
    let mut rnd = |lo: f64, hi: f64| {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((seed >> 11) as f64 / (1u64 << 53) as f64)
    };
    let (mut lookups, mut samples) = (0, 0);
    for episode in 0..episodes {
        let mut tube = Box::new(swap(episode, 0).unwrap());
        let mut c = Clearances::new(n, r, 0.3, Obstacles::of_shapes(&[]));
        let mut brute = f64::INFINITY;
        let mut brute_hints = vec![0usize; n];
        let mut frames = vec![(vt_tube::Vec2::new(1.0, 0.0), vt_tube::Vec2::new(0.0, 1.0)); n];
        let mut uavs: Vec<V3> = Vec::new();
        let mut drift = vec![(0.0, 0.0); n];
        let mut lost = vec![false; n];
        for k in 0..steps {
            if let Some(next) = swap(episode, k).filter(|_| k > 0) {
                *tube = next;
            }
            // A UAV jumps to anywhere in or near the tube now and then (and all at the start).
            let table = tube.samples();
            for i in 0..n {
                if k == 0 || rnd(0.0, 1.0) < 1.0 / 1500.0 {
                    let smp = table[rnd(0.0, 255.99) as usize];
                    let off = rnd(-f64::from(smp.w_right_m) - reach, f64::from(smp.w_left_m) + reach);
                    let p = smp.pos_m + smp.normal() * off as f32;
                    let at = V3::new(f64::from(p.x), f64::from(p.y), 8.0);
                    if k == 0 {
                        uavs.push(at);
                    } else {
                        uavs[i] = at;
                    }
                }
                // Drift along the tube (mostly forward) and across it (towards the boundary
                // as often as away), 1 kHz steps of up to about 3 m/s, with noise.
                if k % 300 == i * 7 % 300 {
                    drift[i] = (rnd(-0.001, 0.003), rnd(-0.0015, 0.0015));
                }
                let (t, nrm) = frames[i];
                let (along, across) = drift[i];
                let step = t * along as f32 + nrm * across as f32;
                uavs[i] += V3::new(f64::from(step.x) + rnd(-5e-4, 5e-4), f64::from(step.y) + rnd(-5e-4, 5e-4), 0.0);
            }
            // A UAV that is down for a while is left out by both.
            lost[9] = (1000..1400).contains(&k) || (2500..2600).contains(&k);
            c.sample(&uavs, &V3::new(10.0, 0.0, 2.0), &lost, &[true; 10], &tube);
            for (i, p) in uavs.iter().enumerate().filter(|(i, _)| !lost[*i]) {
                let q = vt_tube::Vec2::new(p.x as f32, p.y as f32);
                match tube.locate(q, brute_hints[i]) {
                    Some(sec) => {
                        brute_hints[i] = sec.segment;
                        brute = brute.min(f64::from(sec.boundary_distance_m(q)) - r);
                        frames[i] = (sec.tangent, sec.normal);
                    }
                    None => brute = f64::NEG_INFINITY,
                }
            }
            assert_eq!(c.min().uav_boundary_m.to_bits(), brute.to_bits(), "episode {episode}, sample {k}: {} vs {brute}", c.min().uav_boundary_m);
            assert_eq!(c.hints, brute_hints, "episode {episode}, sample {k}");
            samples += n;
        }
        lookups += c.lookups;
    }
    (lookups, samples)
}

#[test]
fn skipping_boundary_lookups_gives_the_brute_force_minimum_and_hints_bit_for_bit() {
    // The paper's tube, swapped mid-flight for a re-planned one and back.
    let (lookups, samples) = walks_match_the_brute_force(2024, 8, 4000, 1.0, |episode, k| match k {
        0 | 3000 => Some(paper_tube()),
        2000 => Some(if episode % 2 == 0 { bend_tube() } else { hairpin_tube() }),
        _ => None,
    });
    // The anchors must also save lookups, or the test proves nothing.
    assert!(lookups * 4 < samples, "{lookups} lookups for {samples} UAV samples");
}

#[test]
fn beside_a_hairpin_the_far_leg_is_accounted_for() {
    // UAVs up to 2.5 m outside a hairpin whose legs' boundaries are 2 m apart: between the
    // legs, beyond the certified radius, where the lookup searches the whole table and the
    // other leg may be the nearer.
    let (lookups, samples) = walks_match_the_brute_force(77, 6, 3000, 2.5, |_, k| (k == 0).then(hairpin_tube));
    assert!(lookups * 3 < samples, "{lookups} lookups for {samples} UAV samples");
}
