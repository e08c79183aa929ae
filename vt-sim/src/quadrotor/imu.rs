//! What the autopilot's loops see of the airframe's attitude and body rates (issue 27 §3):
//! a gyro with white noise and a bias, PX4's gyro low-pass, and an attitude estimate that lags
//! the true one and carries a small tilt misalignment. Off (`[sensing] attitude = "true"`) the
//! loops read the true state, as before.
//!
//! - **Gyro** (per axis): `w_m = w + b + n`. `n` is white with the ADIS16448's noise density
//!   `sigma_g = 3.39e-4 rad/s/sqrt(Hz)` (the RotorS / PX4 Gazebo IMU plugin's default), drawn
//!   per sample as `sigma_g sqrt(f_s)`. `b` is what EKF2's bias estimation leaves: drawn per UAV
//!   at 10 % of the ADIS16448's turn-on bias (0.05 deg/s, project choice), then a random walk
//!   with the ADIS16448's `3.88e-5 rad/s^2/sqrt(Hz)`.
//! - **PX4's gyro low-pass** (`IMU_GYRO_CUTOFF`, 40 Hz, 2nd-order Butterworth; PX4
//!   `src/modules/sensors/vehicle_angular_velocity`, `imu_gyro_parameters.c`) at the rate
//!   controller's 1 kHz ([`IMU_RATE_HZ`]), on the rates both the rate loop's P/I and its D read. PX4's separate D-term
//!   filter (`IMU_DGYRO_CUTOFF`) is not modelled: at the stock D gains it changes nothing here.
//! - **Attitude estimate**: EKF2's output predictor integrates the filtered gyro at the IMU
//!   rate, so its attitude lags the true one by about the filter's delay; modelled as a
//!   first-order lag of `1 / (2 pi IMU_GYRO_CUTOFF)` (4 ms) by spherical interpolation, rotated
//!   by a per-UAV tilt misalignment (accelerometer calibration and board levelling, 0.2 deg per
//!   axis, project choice).
//!
//! Every standard deviation is multiplied by `[sensing] attitude_error_scale`. Seeded per UAV:
//! the same scenario and seed give the same bits.

use crate::disturbance::Noise;
use nalgebra::{UnitQuaternion, Vector3};

/// ADIS16448 gyro noise density, rad/s/sqrt(Hz) (RotorS `gazebo_imu_plugin` default).
pub const GYRO_NOISE_DENSITY: f64 = 3.391_98e-4;
/// ADIS16448 gyro bias random walk, rad/s^2/sqrt(Hz) (RotorS default).
pub const GYRO_BIAS_RANDOM_WALK: f64 = 3.876_5e-5;
/// Residual gyro bias after EKF2's estimation, rad/s (10 % of the ADIS16448's 0.5 deg/s turn-on
/// bias; project choice).
pub const GYRO_RESIDUAL_BIAS: f64 = 0.05 * std::f64::consts::PI / 180.0;
/// PX4 `IMU_GYRO_CUTOFF` default, Hz.
pub const IMU_GYRO_CUTOFF_HZ: f64 = 40.0;
/// Tilt misalignment of the attitude estimate, rad per axis (project choice).
pub const TILT_MISALIGNMENT: f64 = 0.2 * std::f64::consts::PI / 180.0;

/// A 2nd-order Butterworth low-pass in direct form II (PX4 `math::LowPassFilter2p`).
#[derive(Debug, Clone, Copy)]
struct LowPass2 {
    b: [f64; 3],
    a: [f64; 2],
    d: [Vector3<f64>; 2],
    primed: bool,
}

impl LowPass2 {
    /// Cut-off `fc` at sample rate `fs` (Hz); `None` when `fc` is not below Nyquist.
    fn new(fs: f64, fc: f64) -> Option<Self> {
        if !(fs > 0.0 && fc > 0.0 && fc < 0.5 * fs) {
            return None;
        }
        let fr = fs / fc;
        let ohm = (std::f64::consts::PI / fr).tan();
        let c = 1.0 + 2.0 * (std::f64::consts::PI / 4.0).cos() * ohm + ohm * ohm;
        let b0 = ohm * ohm / c;
        Some(Self {
            b: [b0, 2.0 * b0, b0],
            a: [2.0 * (ohm * ohm - 1.0) / c, (1.0 - 2.0 * (std::f64::consts::PI / 4.0).cos() * ohm + ohm * ohm) / c],
            d: [Vector3::zeros(); 2],
            primed: false,
        })
    }

    /// One sample in, one out; the first sample sets the filter to its steady state.
    fn apply(&mut self, x: &Vector3<f64>) -> Vector3<f64> {
        if !self.primed {
            // Steady state for a constant input x: d = x / (1 + a1 + a2).
            let d = x / (1.0 + self.a[0] + self.a[1]);
            self.d = [d, d];
            self.primed = true;
        }
        let d0 = x - self.d[0] * self.a[0] - self.d[1] * self.a[1];
        let y = d0 * self.b[0] + self.d[0] * self.b[1] + self.d[1] * self.b[2];
        self.d[1] = self.d[0];
        self.d[0] = d0;
        y
    }
}

/// The IMU and estimator of one airframe.
#[derive(Debug, Clone)]
pub struct Imu {
    noise: Noise,
    scale: f64,
    bias_rps: Vector3<f64>,
    misalignment: UnitQuaternion<f64>,
    filter: Option<LowPass2>,
    estimate: Option<UnitQuaternion<f64>>,
    /// Time since the last sample, s.
    elapsed_s: f64,
    /// The last sample's attitude estimate and filtered rates (held between samples).
    last: Option<(UnitQuaternion<f64>, Vector3<f64>)>,
}

/// The IMU's sample rate as the loops see it (PX4 publishes the filtered gyro at the rate
/// controller's 1 kHz), Hz.
pub const IMU_RATE_HZ: f64 = 1000.0;

impl Imu {
    /// The IMU of UAV `index` for run seed `seed`, its errors scaled by `scale` (>= 0).
    pub fn new(seed: u64, index: usize, scale: f64) -> Self {
        let scale = if scale.is_finite() { scale.max(0.0) } else { 0.0 };
        let mut noise = Noise::new(seed, 0x1A0_0000 + index as u64);
        let bias_rps = Vector3::new(noise.gauss(), noise.gauss(), noise.gauss()) * (GYRO_RESIDUAL_BIAS * scale);
        let tilt = Vector3::new(noise.gauss(), noise.gauss(), 0.0) * (TILT_MISALIGNMENT * scale);
        Self {
            noise,
            scale,
            bias_rps,
            misalignment: UnitQuaternion::from_scaled_axis(tilt),
            filter: LowPass2::new(IMU_RATE_HZ, IMU_GYRO_CUTOFF_HZ),
            estimate: None,
            elapsed_s: 0.0,
            last: None,
        }
    }

    /// The gyro's current bias, rad/s (FLU).
    pub fn bias_rps(&self) -> Vector3<f64> {
        self.bias_rps
    }

    /// Advances by `h_s` (s) and returns the attitude estimate and the filtered gyro rates
    /// (rad/s, FLU) the loops read, from the true attitude `q` and rates `omega_rps`: a new
    /// sample every `1 / IMU_RATE_HZ` (the first call samples), the last one held in between.
    pub fn measure(&mut self, q: &UnitQuaternion<f64>, omega_rps: &Vector3<f64>, h_s: f64) -> (UnitQuaternion<f64>, Vector3<f64>) {
        if !(h_s > 0.0 && h_s.is_finite()) {
            return self.last.unwrap_or((*q, *omega_rps));
        }
        self.elapsed_s += h_s;
        let period = 1.0 / IMU_RATE_HZ;
        if let (Some(last), true) = (self.last, self.elapsed_s * (1.0 + 1e-9) < period) {
            return last;
        }
        let dt = self.elapsed_s.max(h_s);
        self.elapsed_s = 0.0;
        let walk = GYRO_BIAS_RANDOM_WALK * dt.sqrt() * self.scale;
        self.bias_rps += Vector3::new(self.noise.gauss(), self.noise.gauss(), self.noise.gauss()) * walk;
        let white = GYRO_NOISE_DENSITY / dt.sqrt() * self.scale;
        let raw = omega_rps + self.bias_rps + Vector3::new(self.noise.gauss(), self.noise.gauss(), self.noise.gauss()) * white;
        let rates = self.filter.as_mut().map_or(raw, |f| f.apply(&raw));
        let truth = q * self.misalignment;
        let tau = 1.0 / (std::f64::consts::TAU * IMU_GYRO_CUTOFF_HZ);
        let est = match self.estimate {
            Some(prev) => prev.try_slerp(&truth, (dt / tau).min(1.0), 1e-12).unwrap_or(truth),
            None => truth,
        };
        self.estimate = Some(est);
        self.last = Some((est, rates));
        (est, rates)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_low_pass_passes_dc_and_cuts_at_its_corner() {
        let fs = 2000.0;
        let mut f = LowPass2::new(fs, 40.0).unwrap();
        // DC passes exactly from the first sample.
        let one = Vector3::new(1.0, -2.0, 0.5);
        for _ in 0..10 {
            assert!((f.apply(&one) - one).norm() < 1e-12);
        }
        // A sine at the corner comes out at -3 dB (1/sqrt 2), one at 4x the corner at about -24 dB.
        for (freq, gain) in [(40.0, std::f64::consts::FRAC_1_SQRT_2), (160.0, 1.0 / 257f64.sqrt())] {
            let mut f = LowPass2::new(fs, 40.0).unwrap();
            let mut peak: f64 = 0.0;
            for k in 0..4000 {
                let x = (std::f64::consts::TAU * freq * k as f64 / fs).sin();
                let y = f.apply(&Vector3::new(x, 0.0, 0.0)).x;
                if k > 2000 {
                    peak = peak.max(y.abs());
                }
            }
            assert!((peak - gain).abs() < 0.1 * gain, "{freq} Hz: gain {peak}, expected {gain}");
        }
        assert!(LowPass2::new(60.0, 40.0).is_none(), "above Nyquist");
    }

    #[test]
    fn the_gyro_noise_after_the_filter_has_the_expected_spread_and_the_estimate_lags() {
        let h = 1.0 / IMU_RATE_HZ;
        let mut imu = Imu::new(7, 0, 1.0);
        let q = UnitQuaternion::identity();
        let mut sum = Vector3::zeros();
        let mut sq = 0.0;
        let n = 40_000;
        for _ in 0..n {
            let (_, w) = imu.measure(&q, &Vector3::zeros(), h);
            sum += w;
            sq += w.x * w.x;
        }
        let mean = sum / n as f64;
        // Band-limited white noise around the bias: the two-sided density squared times twice
        // the filter's equivalent noise bandwidth (a 2nd-order Butterworth's is
        // (pi/4)/sin(pi/4) = 1.11 f_c), within 30 %.
        let var = sq / n as f64 - mean.x * mean.x;
        let expected = GYRO_NOISE_DENSITY * GYRO_NOISE_DENSITY * 2.0 * 1.11 * IMU_GYRO_CUTOFF_HZ;
        assert!((var / expected - 1.0).abs() < 0.3, "variance {var:.3e}, expected {expected:.3e}");
        assert!((mean - imu.bias_rps()).norm() < 5.0 * GYRO_RESIDUAL_BIAS, "mean {mean:?} near the bias {:?}", imu.bias_rps());
        // A step in attitude: the estimate gets there in a few time constants, not at once.
        let step = UnitQuaternion::from_euler_angles(0.1, 0.0, 0.0);
        let (e1, _) = imu.measure(&step, &Vector3::zeros(), h);
        assert!(e1.angle_to(&step) > 0.05, "lags");
        for _ in 0..100 {
            imu.measure(&step, &Vector3::zeros(), h);
        }
        // Between samples the last one is held.
        let held = imu.measure(&step, &Vector3::new(5.0, 0.0, 0.0), 0.25 * h);
        assert_eq!(held, imu.measure(&step, &Vector3::new(5.0, 0.0, 0.0), 0.25 * h));
        let (e2, _) = imu.measure(&step, &Vector3::zeros(), h);
        assert!(e2.angle_to(&step) < 3.0 * TILT_MISALIGNMENT + 1e-3, "settled within the misalignment: {}", e2.angle_to(&step));
    }

    #[test]
    fn zero_scale_is_the_truth_filtered() {
        let mut imu = Imu::new(7, 0, 0.0);
        let q = UnitQuaternion::from_euler_angles(0.2, -0.1, 1.0);
        let w = Vector3::new(0.3, 0.0, -0.2);
        let (e, r) = imu.measure(&q, &w, 0.001);
        assert!(e.angle_to(&q) < 1e-12 && (r - w).norm() < 1e-12);
    }
}
