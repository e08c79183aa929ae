//! Dryden turbulence (issue 27; `[disturbances] turbulence`): the low-altitude model of
//! MIL-F-8785C §3.7.2.4 (also MIL-HDBK-1797), per UAV and for the load, with a vertical
//! component, spatially decorrelated over the team's span.
//!
//! # Model
//!
//! - **Intensities and scales** at altitude `h` (ft, at least 10 ft), for the wind at 20 ft
//!   `W20` (light turbulence 15 kt, moderate 30 kt): `sigma_w = 0.1 W20`,
//!   `sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4`; `L_w = h`,
//!   `L_u = L_v = h / (0.177 + 0.000823 h)^1.2`.
//! - **Forming filters** (Taylor's frozen turbulence carried past the vehicle at speed `V`),
//!   `tau = L / V`: `u` first order, `H_u = 1 / (1 + tau_u s)`; `v` and `w` Dryden's
//!   `H = (1 + sqrt 3 tau s) / (1 + tau s)^2`. Each output is scaled to its `sigma`: driven by
//!   unit-intensity white noise, `u`'s lag has variance `1 / (2 tau)` and the second-order
//!   filter `1 / tau` (`(1/2 pi) int |H|^2 = (1/2 pi)(2 pi / tau)`), so the outputs are
//!   multiplied by `sigma sqrt(2 tau)` and `sigma sqrt(tau)`. The `u` lag is discretised
//!   exactly; the second-order filter is two explicit-Euler lags, with `dt / tau < 1e-2` at the
//!   plant rate.
//! - **Carrying speed `V`**: the mean wind's horizontal speed plus the team's speed limit
//!   `v_m` (a hovering multirotor sees the turbulence the wind carries past it), at least
//!   1 m/s. `u` lies along the mean wind (east in calm air), `v` across it, `w` up.
//! - **Spatial decorrelation.** Each body's gust is `sqrt(rho) g_common + sqrt(1 - rho) g_own`,
//!   with `rho = exp(-D / L_u)` over the team's span `D` (twice the formation radius): the
//!   same spectrum and variance for every body, correlated between bodies as two points `D`
//!   apart in an exponential correlation (an approximation of Dryden's longitudinal
//!   correlation, whose length scale is `L_u`).

use crate::disturbance::Noise;
use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// Wind at 20 ft per turbulence level (light turbulence: 15 kt), m/s (MIL-F-8785C Fig. 11).
pub const W20_LIGHT_MPS: f64 = 15.0 * 0.514_444;
/// Lowest altitude the model is evaluated at, m (MIL-F-8785C's low-altitude model starts at
/// 10 ft).
const MIN_ALTITUDE_M: f64 = 3.048;
/// Lowest carrying speed, m/s.
const MIN_SPEED_MPS: f64 = 1.0;
const FT_PER_M: f64 = 1.0 / 0.3048;

/// Dryden's intensities `(sigma_u, sigma_v, sigma_w)`, m/s, and scales `(L_u, L_v, L_w)`, m, at
/// `altitude_m` for a wind at 20 ft of `w20_mps`.
pub fn dryden(altitude_m: f64, w20_mps: f64) -> (V3, V3) {
    let h = altitude_m.max(MIN_ALTITUDE_M) * FT_PER_M;
    let k = 0.177 + 0.000_823 * h;
    let sigma_w = 0.1 * w20_mps;
    let sigma_uv = sigma_w / k.powf(0.4);
    let l_uv = h / k.powf(1.2) / FT_PER_M;
    (V3::new(sigma_uv, sigma_uv, sigma_w), V3::new(l_uv, l_uv, h / FT_PER_M))
}

/// One body's (or the common) gust state.
#[derive(Debug, Clone, Copy, Default)]
struct Filters {
    u: f64,
    /// Two lags each for `v` and `w`.
    v: [f64; 2],
    w: [f64; 2],
}

/// Turbulence over a team: one gust per UAV and one for the load.
#[derive(Debug, Clone)]
pub struct Turbulence {
    sigma: V3,
    tau_s: V3,
    /// Unit vectors of `u` and `v` (horizontal), world ENU.
    along: V3,
    across: V3,
    rho: f64,
    common: Filters,
    own: Vec<Filters>,
    gusts: Vec<V3>,
    noise: Noise,
}

impl Turbulence {
    /// Turbulence of `level` (1 light, 2 moderate; scaled `W20`) at `altitude_m` for `n` UAVs and
    /// the load, carried by `mean_wind_mps` past a team moving at up to `team_speed_mps` over a
    /// span `span_m`; `None` when `level` is 0.
    pub fn new(level: f64, altitude_m: f64, mean_wind_mps: &V3, team_speed_mps: f64, span_m: f64, n: usize, seed: u64) -> Option<Self> {
        if !(level > 0.0 && level.is_finite()) {
            return None;
        }
        let (sigma, scale) = dryden(altitude_m, level * W20_LIGHT_MPS);
        let wind_h = V3::new(mean_wind_mps.x, mean_wind_mps.y, 0.0);
        let speed = (wind_h.norm() + team_speed_mps.max(0.0)).max(MIN_SPEED_MPS);
        let along = if wind_h.norm() > 1e-9 { wind_h.normalize() } else { V3::x() };
        let across = V3::z().cross(&along);
        let mut t = Self {
            sigma,
            tau_s: scale / speed,
            along,
            across,
            rho: (-span_m.max(0.0) / scale.x).exp(),
            common: Filters::default(),
            own: vec![Filters::default(); n + 1],
            gusts: vec![V3::zeros(); n + 1],
            noise: Noise::new(seed, 6),
        };
        // Start from a stationary state: a few correlation times of the slowest filter.
        let settle_dt = 0.05 * t.tau_s.min();
        let steps = (5.0 * t.tau_s.max() / settle_dt).ceil() as usize;
        for _ in 0..steps.min(200_000) {
            t.step(settle_dt);
        }
        Some(t)
    }

    /// The turbulence scenario `s` blows at `altitude_m` over its `n` UAVs and the load (its
    /// level times the campaign intensity, carried by the scaled mean wind past a team at its
    /// speed limit over the take-off formation's span); `None` without turbulence.
    pub fn of_scenario(s: &crate::scenario::Scenario, altitude_m: f64, n: usize, seed: u64) -> Option<Self> {
        let d = &s.disturbances;
        let mean_wind = V3::from(d.wind_mean_mps) * d.intensity;
        Self::new(d.turbulence * d.intensity, altitude_m, &mean_wind, s.controller.v_max_mps, 2.0 * s.uavs.formation_reach_m(), n, seed)
    }

    fn advance(f: &mut Filters, tau: &V3, dt: f64, noise: &mut Noise) {
        let a = (-dt / tau.x).exp();
        f.u = a * f.u + (1.0 - a * a).sqrt() * (1.0 / (2.0 * tau.x)).sqrt() * noise.gauss();
        for (s, t) in [(&mut f.v, tau.y), (&mut f.w, tau.z)] {
            let eta = noise.gauss() / dt.sqrt();
            let k = dt / t;
            s[1] += k * (s[0] - s[1]);
            s[0] += k * (eta - s[0]);
        }
    }

    /// The gust a filter state gives, m/s, world ENU.
    fn output(&self, f: &Filters) -> V3 {
        let sq3 = 3f64.sqrt();
        let u = self.sigma.x * (2.0 * self.tau_s.x).sqrt() * f.u;
        let v = self.sigma.y * self.tau_s.y.sqrt() * (f.v[1] + sq3 * (f.v[0] - f.v[1]));
        let w = self.sigma.z * self.tau_s.z.sqrt() * (f.w[1] + sq3 * (f.w[0] - f.w[1]));
        self.along * u + self.across * v + V3::z() * w
    }

    /// Advances every gust by `dt_s` (s); [`Self::gusts`] then holds them.
    pub fn step(&mut self, dt_s: f64) {
        let tau = self.tau_s;
        Self::advance(&mut self.common, &tau, dt_s, &mut self.noise);
        for f in &mut self.own {
            Self::advance(f, &tau, dt_s, &mut self.noise);
        }
        let c = self.output(&self.common) * self.rho.sqrt();
        let b = (1.0 - self.rho).sqrt();
        for k in 0..self.own.len() {
            let g = self.own.get(k).map_or(V3::zeros(), |f| self.output(f));
            if let Some(slot) = self.gusts.get_mut(k) {
                *slot = c + g * b;
            }
        }
    }

    /// The gust of each UAV, then the load's (last), m/s, world ENU.
    pub fn gusts(&self) -> &[V3] {
        &self.gusts
    }

    /// Intensities `(sigma_u, sigma_v, sigma_w)`, m/s.
    pub fn sigma_mps(&self) -> V3 {
        self.sigma
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// MIL-F-8785C at 50 ft in light turbulence: `sigma_w` = 0.1 W20 = 0.77 m/s,
    /// `sigma_u` = `sigma_w / 0.218^0.4` = 1.42 m/s, `L_w` = 50 ft, `L_u` = 50 / 0.218^1.2 ft.
    #[test]
    fn intensities_and_scales_by_hand() {
        let (s, l) = dryden(50.0 * 0.3048, W20_LIGHT_MPS);
        let k: f64 = 0.177 + 0.000_823 * 50.0;
        assert!((s.z - 0.1 * W20_LIGHT_MPS).abs() < 1e-9);
        assert!((s.x - s.z / k.powf(0.4)).abs() < 1e-9 && s.x > 1.3 && s.x < 1.5, "{s:?}");
        assert!((l.z - 50.0 * 0.3048).abs() < 1e-9);
        assert!((l.x - 50.0 / k.powf(1.2) * 0.3048).abs() < 1e-9);
    }

    /// The simulated gusts have Dryden's standard deviations per axis (long run, 1 kHz).
    #[test]
    fn gusts_have_the_model_intensities() {
        let mut t = Turbulence::new(1.0, 15.0, &V3::new(3.0, 0.0, 0.0), 1.5, 0.0, 1, 3).unwrap();
        let (mut s2, mut count) = (V3::zeros(), 0.0);
        for k in 0..2_000_000 {
            t.step(0.001);
            if k % 10 == 0 {
                let g = t.gusts()[0];
                s2 += g.component_mul(&g);
                count += 1.0;
            }
        }
        let sd = (s2 / count).map(f64::sqrt);
        let want = t.sigma_mps();
        for i in 0..3 {
            assert!((sd[i] / want[i] - 1.0).abs() < 0.2, "axis {i}: {} vs {}", sd[i], want[i]);
        }
    }

    /// Two bodies over a span short against `L_u` move nearly together; far apart, independently.
    #[test]
    fn nearby_bodies_are_correlated() {
        let corr = |span: f64| {
            let mut t = Turbulence::new(1.0, 15.0, &V3::zeros(), 1.5, span, 1, 5).unwrap();
            let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
            for _ in 0..400_000 {
                t.step(0.002);
                let (a, b) = (t.gusts()[0].z, t.gusts()[1].z);
                ab += a * b;
                aa += a * a;
                bb += b * b;
            }
            ab / (aa * bb).sqrt()
        };
        assert!(corr(2.0) > 0.9 && corr(1000.0) < 0.2, "{} {}", corr(2.0), corr(1000.0));
        assert!(Turbulence::new(0.0, 15.0, &V3::zeros(), 1.5, 6.0, 3, 1).is_none());
    }
}
