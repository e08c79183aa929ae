//! Disturbances of the simulated world (all seeded, all off by default): Gaussian sensor
//! noise, measurement latency, wind with filtered-noise gusts acting through quadratic drag,
//! and draws of the plant's parameter errors. The controllers see only what these produce.

use crate::link::SplitMix64;
use crate::plant::Plant;
use crate::scenario::DisturbanceSpec;
use crate::sensing::{PositionErrors, Receiver, SensingSpec};
use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// Air density, kg/m^3 (ISA sea level).
pub const AIR_DENSITY_KG_M3: f64 = 1.225;

/// Seeded Gaussian and uniform draws (Box-Muller on SplitMix64).
#[derive(Debug, Clone)]
pub struct Noise {
    rng: SplitMix64,
    spare: Option<f64>,
}

impl Noise {
    /// A generator for stream `stream` of seed `seed` (streams are independent).
    pub fn new(seed: u64, stream: u64) -> Self {
        Self { rng: SplitMix64::new(seed ^ stream.wrapping_mul(0xA24B_AED4_963E_E407)), spare: None }
    }

    /// Standard normal draw.
    pub fn gauss(&mut self) -> f64 {
        if let Some(s) = self.spare.take() {
            return s;
        }
        let u1 = self.rng.next_f64().max(f64::MIN_POSITIVE);
        let u2 = self.rng.next_f64();
        let r = (-2.0 * u1.ln()).sqrt();
        let a = std::f64::consts::TAU * u2;
        self.spare = Some(r * a.sin());
        r * a.cos()
    }

    /// Uniform in [-a, a].
    pub fn uniform_pm(&mut self, a: f64) -> f64 {
        a * (2.0 * self.rng.next_f64() - 1.0)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.rng.next_f64()
    }

    /// A vector of independent normal draws with std. dev. `sigma` (no draw when 0).
    pub fn vec3(&mut self, sigma: f64) -> V3 {
        if sigma > 0.0 {
            V3::new(self.gauss(), self.gauss(), self.gauss()) * sigma
        } else {
            V3::zeros()
        }
    }
}

/// Uniform wind with horizontal gusts: a first-order (Ornstein-Uhlenbeck) process per axis,
/// discretised exactly: `g <- g e + sigma sqrt(1 - e^2) n`, `e = exp(-dt/tau)`.
#[derive(Debug, Clone)]
pub struct Wind {
    mean_mps: V3,
    gust_mps: [f64; 2],
    std_mps: f64,
    tau_s: f64,
    noise: Noise,
}

impl Wind {
    /// Wind of the scenario (scaled by its intensity), gusts starting from a stationary draw.
    pub fn new(d: &DisturbanceSpec, seed: u64) -> Self {
        let k = d.intensity;
        let mut noise = Noise::new(seed, 2);
        let std = d.gust_std_mps * k;
        let gust = [noise.gauss() * std, noise.gauss() * std];
        Self { mean_mps: V3::from(d.wind_mean_mps) * k, gust_mps: gust, std_mps: std, tau_s: d.gust_tau_s, noise }
    }

    /// True when there is no wind at all.
    pub fn is_calm(&self) -> bool {
        self.mean_mps == V3::zeros() && self.std_mps == 0.0
    }

    /// Advances the gusts by `dt_s` and returns the wind velocity, m/s.
    pub fn step(&mut self, dt_s: f64) -> V3 {
        if self.std_mps > 0.0 {
            let e = (-dt_s / self.tau_s).exp();
            let s = self.std_mps * (1.0 - e * e).sqrt();
            for g in &mut self.gust_mps {
                *g = *g * e + s * self.noise.gauss();
            }
        }
        self.mean_mps + V3::new(self.gust_mps[0], self.gust_mps[1], 0.0)
    }
}

/// Height of the scenario's wind, m: `wind_mean_mps` and the gusts are the wind at 20 ft, the
/// `W20` of MIL-F-8785C's low-altitude model (§3.7.2.4), and the wind at and above it.
pub const WIND_REFERENCE_HEIGHT_M: f64 = 20.0 * 0.3048;

/// The share of the reference wind blowing at `height_m` above the ground over terrain of
/// roughness length `roughness_m`: MIL-F-8785C's wind shear (the surface layer's log law),
/// `ln(h / z0) / ln(h_20 / z0)`, 0 at and below `z0`, held at 1 from 20 ft up (the scenario's
/// wind is the strongest a body meets; docs/plant.md, "Wind near the ground"). A roughness of
/// 0 (or not finite) gives the uniform wind: 1 everywhere.
#[must_use]
pub fn shear_factor(height_m: f64, roughness_m: f64) -> f64 {
    if !(roughness_m > 0.0 && roughness_m < WIND_REFERENCE_HEIGHT_M) || height_m >= WIND_REFERENCE_HEIGHT_M {
        return 1.0;
    }
    if height_m.is_nan() || height_m <= roughness_m {
        return 0.0;
    }
    ((height_m / roughness_m).ln() / (WIND_REFERENCE_HEIGHT_M / roughness_m).ln()).clamp(0.0, 1.0)
}

/// Quadratic drag `1/2 rho C_d A |v_rel| v_rel`, `v_rel = wind - v`, N.
pub fn drag_n(wind_mps: &V3, vel_mps: &V3, drag_area_m2: f64) -> V3 {
    let rel = wind_mps - vel_mps;
    rel * (0.5 * AIR_DENSITY_KG_M3 * drag_area_m2 * rel.norm())
}

/// One sample of the true state that sensors read.
#[derive(Debug, Clone, Default)]
pub struct Snapshot {
    /// UAV positions, m.
    pub uav_pos_m: Vec<V3>,
    /// UAV velocities, m/s.
    pub uav_vel_mps: Vec<V3>,
    /// Load position, m.
    pub load_pos_m: V3,
    /// Load velocity, m/s.
    pub load_vel_mps: V3,
    /// Simulated time of the sample, ms (`time_boot_ms` of the measurements made from it).
    pub time_ms: u32,
}

impl Snapshot {
    /// Makes `self` a copy of `other`, reusing its own buffers (no allocation once they are
    /// large enough; the derived `clone_from` allocates anew).
    pub fn copy_from(&mut self, other: &Snapshot) {
        self.uav_pos_m.clear();
        self.uav_pos_m.extend_from_slice(&other.uav_pos_m);
        self.uav_vel_mps.clear();
        self.uav_vel_mps.extend_from_slice(&other.uav_vel_mps);
        self.load_pos_m = other.load_pos_m;
        self.load_vel_mps = other.load_vel_mps;
        self.time_ms = other.time_ms;
    }

    fn fill(&mut self, p: &Plant, time_ms: u32) {
        self.time_ms = time_ms;
        self.uav_pos_m.clear();
        self.uav_vel_mps.clear();
        self.uav_pos_m.extend(p.uavs.iter().map(|u| u.pos_m));
        self.uav_vel_mps.extend(p.uavs.iter().map(|u| u.vel_mps));
        self.load_pos_m = p.load.pos_m;
        self.load_vel_mps = p.load.vel_mps;
    }
}

/// Sensors: a ring of past states (latency, in low-level periods) and additive noise.
#[derive(Debug, Clone)]
pub struct Sensors {
    ring: Vec<Snapshot>,
    head: usize,
    filled: usize,
    pos_sigma_m: f64,
    vel_sigma_mps: f64,
    noise: Noise,
    /// GNSS-like position errors (`[sensing] position`; `None`: white noise only).
    errors: Option<PositionErrors>,
}

impl Sensors {
    /// Sensors with `latency_steps` low-level periods of delay; `sensing` gives `n` UAV
    /// receivers and the load tracker their errors, stepped every `dt_s` (one low-level period).
    pub fn new(d: &DisturbanceSpec, sensing: &SensingSpec, n: usize, dt_s: f64, latency_steps: usize, seed: u64) -> Self {
        Self {
            errors: PositionErrors::new(sensing, n, dt_s, seed),
            ring: vec![Snapshot::default(); latency_steps + 1],
            head: 0,
            filled: 0,
            pos_sigma_m: d.position_noise_m * d.intensity,
            vel_sigma_mps: d.velocity_noise_mps * d.intensity,
            noise: Noise::new(seed, 1),
        }
    }

    /// Stores the current true state, sampled at `time_ms` (call once per low-level period).
    pub fn sample(&mut self, p: &Plant, time_ms: u32) {
        self.head = (self.head + 1) % self.ring.len();
        if let Some(s) = self.ring.get_mut(self.head) {
            s.fill(p, time_ms);
        }
        self.filled = (self.filled + 1).min(self.ring.len());
        if let Some(e) = &mut self.errors {
            e.step();
        }
    }

    /// The state `latency` ago (the oldest available at start-up).
    pub fn delayed(&self) -> &Snapshot {
        let n = self.ring.len();
        let back = self.filled.saturating_sub(1).min(n - 1);
        &self.ring[(self.head + n - back) % n]
    }

    /// Position measurement of receiver `r`: `x` plus its GNSS-like error, if any, plus white
    /// noise. What a UAV's neighbours receive is its own receiver's error (`Receiver::Uav`).
    pub fn position(&mut self, r: Receiver, x: &V3) -> V3 {
        let e = self.errors.as_ref().map_or(V3::zeros(), |e| e.of(r));
        x + e + self.noise.vec3(self.pos_sigma_m)
    }

    /// Velocity measurement: `v` plus noise.
    pub fn velocity(&mut self, v: &V3) -> V3 {
        v + self.noise.vec3(self.vel_sigma_mps)
    }
}

/// The plant's true parameters drawn around the nominal ones (controllers keep the nominal).
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterDraw {
    /// Cable length factors, one per cable.
    pub cable_length: Vec<f64>,
    /// Cable stiffness factors.
    pub cable_stiffness: Vec<f64>,
    /// UAV mass factors.
    pub uav_mass: Vec<f64>,
    /// Load mass factor.
    pub load_mass: f64,
    /// Maximum-thrust factors, one per UAV: the plant's true maximum over the one the firmware
    /// believes (`VL_T_MAX`; issue 27). Drawn after the others, so that they keep their values.
    pub thrust_scale: Vec<f64>,
}

impl ParameterDraw {
    /// Draws the factors `1 + U(-e, e)` for `n` UAVs.
    pub fn draw(d: &DisturbanceSpec, n: usize, seed: u64) -> Self {
        let k = d.intensity;
        let mut r = Noise::new(seed, 3);
        let mut f = |e: f64| 1.0 + r.uniform_pm(e * k);
        Self {
            cable_length: (0..n).map(|_| f(d.cable_length_error)).collect(),
            cable_stiffness: (0..n).map(|_| f(d.cable_stiffness_error)).collect(),
            uav_mass: (0..n).map(|_| f(d.uav_mass_error)).collect(),
            load_mass: f(d.load_mass_error),
            thrust_scale: (0..n).map(|_| f(d.thrust_scale_error)).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// MIL-F-8785C's shear by hand (0.15 ft roughness): 0.2560 at 0.16 m, 0.8550 at 3 m; 1 from
    /// 20 ft up, 0 at and below the roughness, growing in between; uniform with no roughness.
    #[test]
    fn the_shear_follows_the_log_law_below_20_ft() {
        let z0 = 0.15 * 0.3048;
        assert!((shear_factor(0.16, z0) - 0.2560).abs() < 1e-4, "{}", shear_factor(0.16, z0));
        assert!((shear_factor(3.0, z0) - 0.8550).abs() < 1e-4, "{}", shear_factor(3.0, z0));
        assert_eq!(shear_factor(WIND_REFERENCE_HEIGHT_M, z0), 1.0);
        assert_eq!(shear_factor(40.0, z0), 1.0);
        assert_eq!(shear_factor(z0, z0), 0.0);
        assert_eq!(shear_factor(-1.0, z0), 0.0);
        assert_eq!(shear_factor(f64::NAN, z0), 0.0);
        let mut last = 0.0;
        for k in 0..=60 {
            let f = shear_factor(0.1 * f64::from(k) + 0.05, z0);
            assert!(f >= last && f <= 1.0, "{k}: {f}");
            last = f;
        }
        for h in [0.0, 0.16, 3.0, 100.0] {
            assert_eq!(shear_factor(h, 0.0), 1.0);
            assert_eq!(shear_factor(h, f64::NAN), 1.0);
        }
    }

    #[test]
    fn gaussian_draws_have_unit_variance_and_are_seeded() {
        let mut a = Noise::new(5, 1);
        let xs: Vec<f64> = (0..20_000).map(|_| a.gauss()).collect();
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / xs.len() as f64;
        assert!(mean.abs() < 0.03 && (var - 1.0).abs() < 0.05, "mean {mean} var {var}");
        let mut b = Noise::new(5, 1);
        assert_eq!(xs[0], b.gauss());
        assert_ne!(Noise::new(5, 2).gauss(), xs[0]);
    }

    #[test]
    fn gusts_have_the_requested_spread() {
        let d = DisturbanceSpec { gust_std_mps: 1.0, gust_tau_s: 0.5, ..DisturbanceSpec::default() };
        let mut w = Wind::new(&d, 3);
        let xs: Vec<f64> = (0..200_000).map(|_| w.step(0.01).x).collect();
        let var = xs.iter().map(|x| x * x).sum::<f64>() / xs.len() as f64;
        assert!((var.sqrt() - 1.0).abs() < 0.1, "gust std {}", var.sqrt());
    }

    #[test]
    fn drag_opposes_relative_motion() {
        let f = drag_n(&V3::zeros(), &V3::new(2.0, 0.0, 0.0), 0.1);
        assert!((f.x + 0.5 * AIR_DENSITY_KG_M3 * 0.1 * 4.0).abs() < 1e-12);
        assert_eq!(drag_n(&V3::new(1.0, 1.0, 0.0), &V3::new(1.0, 1.0, 0.0), 0.1), V3::zeros());
    }

    #[test]
    fn parameter_draws_stay_within_bounds() {
        let d = DisturbanceSpec { cable_stiffness_error: 0.5, load_mass_error: 0.1, ..DisturbanceSpec::default() };
        let p = ParameterDraw::draw(&d, 10, 9);
        assert!(p.cable_stiffness.iter().all(|k| (0.5..=1.5).contains(k)));
        assert!(p.cable_length.iter().all(|k| *k == 1.0));
        assert!((0.9..=1.1).contains(&p.load_mass));
        assert!(p.thrust_scale.iter().all(|k| *k == 1.0));
        // The thrust draw comes last: turning it on leaves the other draws as they were.
        let t = ParameterDraw::draw(&DisturbanceSpec { thrust_scale_error: 0.2, ..d }, 10, 9);
        assert_eq!((&t.cable_stiffness, t.load_mass), (&p.cable_stiffness, p.load_mass));
        assert!(t.thrust_scale.iter().all(|k| (0.8..=1.2).contains(k)) && t.thrust_scale.iter().any(|k| *k != 1.0));
    }
}
