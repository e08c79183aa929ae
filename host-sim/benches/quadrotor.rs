//! Criterion benchmark of the rigid-body quadrotor step (issue 14; figure in docs/plant.md).
//!
//! `quadrotor_step/1000`: 1000 calls of `Quadrotor::step` at 1 kHz (one simulated second of
//! one UAV), paper preset, under a slanted cable force, a 3 m/s wind and a target that
//! alternates between two tilts every 100 ms, so that the attitude loop (250 Hz), the rate
//! loop and mixer (1 kHz), the motors, drag and the cable torque all do real work. The
//! 10-UAV mission's budget (500 UAV-seconds per wall second, controllers included) leaves the
//! plant well under 2 ms per 1000 steps.
// A benchmark that cannot set itself up has nothing to measure: it stops with a message.
#![allow(clippy::expect_used)]

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use host_sim::quadrotor::{AttitudeTarget, QuadParams, Quadrotor};
use nalgebra::{UnitQuaternion, Vector3};

/// Plant step, s (1 kHz).
const H_S: f64 = 0.001;
/// Steps per measured iteration (one simulated second).
const STEPS: u64 = 1000;
/// Steps between target switches (100 ms).
const SWITCH_STEPS: u64 = 100;

fn quadrotor_step(c: &mut Criterion) {
    let cable = Vector3::new(2.0, -1.0, -12.0);
    let wind = Vector3::new(3.0, 0.0, 0.0);
    let mut quad = Quadrotor::new(QuadParams::paper(), Vector3::new(0.0, 0.0, 10.0), Vector3::zeros())
        .expect("paper preset is valid");
    quad.trim_hover(cable);
    let hover = *quad.autopilot().target();
    let targets = [
        AttitudeTarget { attitude: UnitQuaternion::from_euler_angles(0.05, -0.08, 0.0) * hover.attitude, ..hover },
        AttitudeTarget { attitude: UnitQuaternion::from_euler_angles(-0.05, 0.08, 0.0) * hover.attitude, ..hover },
    ];
    let mut group = c.benchmark_group("quadrotor_step");
    group.throughput(Throughput::Elements(STEPS));
    group.bench_function("1000", |b| {
        b.iter(|| {
            for k in 0..STEPS {
                let target = if (k / SWITCH_STEPS).is_multiple_of(2) { &targets[0] } else { &targets[1] };
                quad.step(black_box(target), black_box(cable), black_box(wind), H_S);
            }
            black_box(quad.pos_m())
        });
    });
    group.finish();
}

criterion_group!(benches, quadrotor_step);
criterion_main!(benches);
