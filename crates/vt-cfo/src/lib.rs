//! Low-level velocity loop of the cooperative-transport controller: a compensation function
//! observer for the cable force, the PID + feedforward thrust law, the thrust clamp and the
//! thrust-to-attitude conversion (eq:2-2, eq:2-3, REFERENCE §4).
//!
//! - [`observer`]: [`Cfo`], the compensation function observer that estimates the cable force
//!   `f_hat` (REFERENCE §4, Qi et al. 2022).
//! - [`velocity_loop`]: [`VelocityLoop`], `T_d = m (Kp e_v + Ki int e_v + Kd e_v') + f_hat - G`
//!   (eq:2-3) with anti-windup and a failsafe.
//! - [`prediction`]: measurement-delay compensation (the observer on the sample's timeline,
//!   the state predicted to now).
//! - [`thrust`]: [`ThrustLimits`] (magnitude and tilt clamp, vertical priority) and the
//!   conversion between a thrust vector and an attitude setpoint ([`thrust_to_attitude`],
//!   [`attitude_to_thrust`]).
//!
//! # Frames
//!
//! World frame ENU (`x` east, `y` north, `z` up), gravity `g_vec = (0, 0, -g)`
//! ([`gravity_mps2`]). Body frame FLU (`x` forward, `y` left, `z` up, along the thrust).
//! Quaternions are nalgebra's `UnitQuaternion` (Hamilton convention) and rotate body vectors into
//! the world frame (`v_world = q * v_body`).
//!
//! Plant (eq:1-1, REFERENCE §1): `m v' = T + G - f`, `G = m g_vec`, where `f` is the cable term
//! (the force the cable exerts on the UAV is `-f`).
//!
//! Everything is `f32`, `no_std`, allocation-free, and the control step runs no trigonometry.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

mod error;
pub mod observer;
pub mod prediction;
mod status;
pub mod thrust;
pub mod velocity_loop;

pub use error::CfoError;
pub use observer::{Cfo, CfoParams, MAX_BANDWIDTH_PERIOD};
pub use prediction::{age_s, extrapolate_constant_velocity, Prediction, DELAY_CAPACITY_STEPS};
pub use status::Status;
pub use thrust::{attitude_to_thrust, thrust_to_attitude, AttitudeSetpoint, ThrustLimits};
pub use velocity_loop::{loaded_bandwidth_cap, PidGains, ThrustOutput, VelocityLoop, VelocityLoopParams, FULL_SHARE_RATIO, LIGHT_SHARE_MIN_LAG_S, LIGHT_SHARE_RATIO, UNLOADED_BANDWIDTH_RAD_S};

use nalgebra::Vector3;

/// Standard gravity, m/s² (REFERENCE §1: `g_vec = (0, 0, -g)`).
pub const GRAVITY_MPS2: f32 = 9.81;

/// The gravity vector `g_vec = (0, 0, -g)` in the ENU world frame, m/s² (REFERENCE §1).
#[must_use]
pub fn gravity_mps2() -> Vector3<f32> {
    Vector3::new(0.0, 0.0, -GRAVITY_MPS2)
}
