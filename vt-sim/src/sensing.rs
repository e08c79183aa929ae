//! GNSS-like position errors (issue 27): each receiver's error is a first-order Gauss-Markov
//! (Ornstein-Uhlenbeck) process plus a component common to the whole team, in place of white
//! noise alone (`[sensing] position`; docs/robustness.md, "Sensing like a real aircraft").
//!
//! # Model and sources
//!
//! `e_r(t) = b_r(t) + c(t)` for receiver `r` (each UAV, and the load tracker, a receiver of
//! the same class on the load). `b_r` is independent per receiver: multipath and receiver noise.
//! `c` is shared by receivers a few hundred metres apart: atmosphere, ephemeris and clocks, or
//! for RTK the base station's own error. Each axis is an OU process with standard deviation
//! `sigma` and correlation time `tau`, discretised exactly:
//! `x <- a x + sigma sqrt(1 - a^2) n`, `a = exp(-dt / tau)`. Started from its stationary
//! distribution, so the error is there at take-off, as it is on a real aircraft.
//!
//! - A Gauss-Markov (OU) process fits stationary single-frequency GPS position series better
//!   than white noise (Sensors 2020, 20(21), 6050, University of Otago).
//! - `gnss` (standalone receiver):
//!   - individual 0.5 m per horizontal axis, 1.0 m vertical, `tau` 60 s: code multipath
//!     0.5 m at zenith (Joerger & Pervan 2016, NAVIGATION); the autocorrelation of a standalone
//!     receiver's horizontal error bends at about one minute (D. L. Wilson, Garmin 12XL tests);
//!   - common 1.0 m horizontal, 2.0 m vertical, `tau` 900 s: the atmospheric delays' correlation
//!     times are 900-2700 s (Joerger & Pervan 2020);
//!   - together: 1.12 m per horizontal axis, 1.3 m CEP, against the 1.5 m CEP of a current
//!     multi-band receiver's standalone fix (u-blox ZED-F9P data sheet, UBX-17051259).
//! - `rtk`: individual 0.01 m horizontal, 0.02 m vertical, `tau` 60 s (ZED-F9P RTK:
//!   0.01 m + 1 ppm CEP); common 0.02 m horizontal, 0.03 m vertical, `tau` 900 s (the base
//!   station's survey).

use crate::disturbance::Noise;
use nalgebra::Vector3;
use serde::Deserialize;

type V3 = Vector3<f64>;

/// Position sensing model (`[sensing] position`).
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PositionModel {
    /// White noise only (`disturbances.position_noise_m`): the project's model before issue 27.
    #[default]
    White,
    /// RTK GNSS (cm level).
    Rtk,
    /// Standalone GNSS (metre level).
    Gnss,
}

/// One Gauss-Markov component: standard deviation per axis (x, y horizontal; z vertical), m,
/// and correlation time, s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Component {
    /// Horizontal standard deviation per axis, m.
    pub sigma_h_m: f64,
    /// Vertical standard deviation, m.
    pub sigma_v_m: f64,
    /// Correlation time, s.
    pub tau_s: f64,
}

impl PositionModel {
    /// `(individual, common)` components of the preset, or `None` for white noise (sources in
    /// the module documentation).
    pub fn components(self) -> Option<(Component, Component)> {
        match self {
            Self::White => None,
            Self::Rtk => Some((
                Component { sigma_h_m: 0.01, sigma_v_m: 0.02, tau_s: 60.0 },
                Component { sigma_h_m: 0.02, sigma_v_m: 0.03, tau_s: 900.0 },
            )),
            Self::Gnss => Some((
                Component { sigma_h_m: 0.5, sigma_v_m: 1.0, tau_s: 60.0 },
                Component { sigma_h_m: 1.0, sigma_v_m: 2.0, tau_s: 900.0 },
            )),
        }
    }

    /// Name in scenarios and reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::White => "white",
            Self::Rtk => "rtk",
            Self::Gnss => "gnss",
        }
    }
}

/// `[sensing]`: how the team's receivers see positions.
#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensingSpec {
    /// Position model (default `white`).
    pub position: PositionModel,
    /// Multiplies every standard deviation of the preset (default 1; the GNSS survival figure
    /// scales it).
    pub error_scale: Option<f64>,
    /// What the autopilot's loops read (default `true`: the true attitude and rates; `px4`: a
    /// noisy, biased gyro behind PX4's 40 Hz low-pass and a lagging, misaligned attitude
    /// estimate, `quadrotor::imu`). Rigid-body plant only.
    pub attitude: AttitudeModel,
    /// Multiplies every standard deviation of the `px4` attitude model (default 1).
    pub attitude_error_scale: Option<f64>,
}

/// `[sensing] attitude`: what the autopilot's attitude and rate loops read.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AttitudeModel {
    /// The true attitude and body rates.
    #[default]
    True,
    /// Gyro noise and bias, PX4's `IMU_GYRO_CUTOFF` low-pass, a lagging and misaligned
    /// attitude estimate (`quadrotor::imu`).
    Px4,
}

impl SensingSpec {
    /// The error scale, default 1.
    pub fn scale(&self) -> f64 {
        self.error_scale.unwrap_or(1.0)
    }
}

/// Which receiver made a position measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Receiver {
    /// UAV `i`'s own receiver (its measurement, and what its neighbours receive from it).
    Uav(usize),
    /// The load tracker.
    Load,
}

/// One OU process per axis.
#[derive(Debug, Clone, Copy)]
struct Process {
    x: V3,
    a: f64,
    q: V3,
}

impl Process {
    fn new(c: &Component, scale: f64, dt_s: f64, noise: &mut Noise) -> Self {
        let sigma = V3::new(c.sigma_h_m, c.sigma_h_m, c.sigma_v_m) * scale;
        let a = (-dt_s / c.tau_s).exp();
        let x = V3::new(noise.gauss(), noise.gauss(), noise.gauss()).component_mul(&sigma);
        Self { x, a, q: sigma * (1.0 - a * a).sqrt() }
    }

    fn step(&mut self, noise: &mut Noise) {
        let n = V3::new(noise.gauss(), noise.gauss(), noise.gauss());
        self.x = self.x * self.a + self.q.component_mul(&n);
    }
}

/// The team's position errors now.
#[derive(Debug, Clone)]
pub struct PositionErrors {
    uavs: Vec<Process>,
    load: Process,
    common: Process,
    noise: Noise,
}

impl PositionErrors {
    /// Errors of `spec` for `n` UAVs, stepped every `dt_s`, seeded by `seed`; `None` for white
    /// noise.
    pub fn new(spec: &SensingSpec, n: usize, dt_s: f64, seed: u64) -> Option<Self> {
        let (ind, com) = spec.position.components()?;
        let k = spec.scale();
        let mut noise = Noise::new(seed, 5);
        let uavs = (0..n).map(|_| Process::new(&ind, k, dt_s, &mut noise)).collect();
        let load = Process::new(&ind, k, dt_s, &mut noise);
        let common = Process::new(&com, k, dt_s, &mut noise);
        Some(Self { uavs, load, common, noise })
    }

    /// Advances every process by one period.
    pub fn step(&mut self) {
        for p in &mut self.uavs {
            p.step(&mut self.noise);
        }
        self.load.step(&mut self.noise);
        self.common.step(&mut self.noise);
    }

    /// The error of receiver `r` now, m (zero for an unknown UAV).
    pub fn of(&self, r: Receiver) -> V3 {
        let own = match r {
            Receiver::Uav(i) => self.uavs.get(i).map_or(V3::zeros(), |p| p.x),
            Receiver::Load => self.load.x,
        };
        own + self.common.x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gnss(n: usize) -> PositionErrors {
        PositionErrors::new(&SensingSpec { position: PositionModel::Gnss, error_scale: None, ..SensingSpec::default() }, n, 0.1, 7).unwrap()
    }

    #[test]
    fn white_has_no_process() {
        assert!(PositionErrors::new(&SensingSpec::default(), 3, 0.002, 1).is_none());
    }

    /// The stationary spread is the preset's `sqrt(sigma_ind^2 + sigma_com^2)`, and the
    /// one-step autocorrelation is `exp(-dt / tau)` (over many independent teams).
    #[test]
    fn spread_and_correlation_match_the_preset() {
        let (mut s2, mut cov, mut count) = (0.0, 0.0, 0.0);
        for seed in 0..4000 {
            let mut e = PositionErrors::new(&SensingSpec { position: PositionModel::Gnss, error_scale: None, ..SensingSpec::default() }, 1, 10.0, seed).unwrap();
            let x0 = e.of(Receiver::Uav(0)).x;
            e.step();
            let x1 = e.of(Receiver::Uav(0)).x;
            s2 += x0 * x0;
            cov += x0 * x1;
            count += 1.0;
        }
        let sigma = (s2 / count).sqrt();
        assert!((sigma - (0.25f64 + 1.0).sqrt()).abs() < 0.06, "sigma {sigma}");
        let expect = (0.25 * (-10.0f64 / 60.0).exp() + 1.0 * (-10.0f64 / 900.0).exp()) / 1.25;
        assert!((cov / s2 - expect).abs() < 0.04, "rho {} vs {expect}", cov / s2);
    }

    /// Neighbours share the common part: the error between two UAVs is smaller than each.
    #[test]
    fn the_common_part_cancels_between_neighbours() {
        let (mut abs2, mut rel2) = (0.0, 0.0);
        for k in 0..2000 {
            let mut e = gnss(2);
            for _ in 0..(k % 7) {
                e.step();
            }
            let (a, b) = (e.of(Receiver::Uav(0)), e.of(Receiver::Uav(1)));
            abs2 += a.x * a.x;
            rel2 += (a.x - b.x) * (a.x - b.x);
        }
        // Relative: sqrt(2) x 0.5 m; absolute: 1.12 m.
        assert!(rel2 < 0.7 * abs2, "relative {rel2} absolute {abs2}");
        let e = gnss(2);
        assert_eq!(e.of(Receiver::Uav(9)), e.common.x, "an unknown UAV gets the common part only");
    }

    #[test]
    fn seeded_and_scaled() {
        let a = gnss(3);
        let b = gnss(3);
        assert_eq!(a.of(Receiver::Load), b.of(Receiver::Load));
        let half = PositionErrors::new(&SensingSpec { position: PositionModel::Gnss, error_scale: Some(0.5), ..SensingSpec::default() }, 3, 0.1, 7).unwrap();
        assert!((half.of(Receiver::Load) - a.of(Receiver::Load) * 0.5).norm() < 1e-12);
    }
}
