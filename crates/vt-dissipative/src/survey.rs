//! The pre-flight survey: the take-off positions the team calibrates from, averaged over the
//! samples received while it hovers before `MISSION_START` (docs/design.md, "Take-off survey").
//!
//! Calibration (`calibrate`), the take-off formation (eq:2-7 rest lengths, `Formation::
//! from_takeoff`) and the capacity plan are all computed once, from the take-off positions. Taken
//! from one noisy sample they carry its noise for the whole flight: at 3x the nominal position
//! noise (0.15 m per axis) the spring rest lengths were about 0.2 m off, enough to bring two UAVs
//! under the 0.4 m floor mid-tube. Averaged over `k` samples the noise falls as `1/sqrt(k)`.
//!
//! Each source (own position, load position, each team member's position) keeps a running mean:
//! the exact mean of the first `window` samples, then an exponential moving average with gain
//! `1/window` (effective sample size `2 window - 1`), so a team that moved (the climb to the
//! take-off hover) is forgotten within a few windows. The survey only averages; what counts as
//! fresh at `MISSION_START` is the caller's (the companion's freshness timeouts).

use nalgebra::Vector3;

/// The running mean of one position source, m (world ENU).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionMean {
    mean_m: Vector3<f32>,
    count: u32,
}

impl Default for PositionMean {
    fn default() -> Self {
        Self::new()
    }
}

impl PositionMean {
    /// No sample yet.
    #[must_use]
    pub const fn new() -> Self {
        Self { mean_m: Vector3::new(0.0, 0.0, 0.0), count: 0 }
    }

    /// Adds a sample, m; non-finite samples are ignored. `window` (samples, >= 1; 0 counts as
    /// 1): exact mean up to it, then an exponential average with gain `1/window`.
    pub fn push(&mut self, sample_m: &Vector3<f32>, window: u32) {
        if !sample_m.iter().all(|x| x.is_finite()) {
            return;
        }
        self.count = self.count.saturating_add(1);
        let k = self.count.min(window.max(1));
        // k = 1 takes the sample as is (no 0 * inf, and the first sample is exact).
        if k == 1 {
            self.mean_m = *sample_m;
        } else {
            self.mean_m += (sample_m - self.mean_m) / k as f32;
        }
    }

    /// The mean, m (`None` before the first sample).
    #[must_use]
    pub fn mean(&self) -> Option<Vector3<f32>> {
        (self.count > 0).then_some(self.mean_m)
    }

    /// Samples received (saturating).
    #[must_use]
    pub fn count(&self) -> u32 {
        self.count
    }
}

/// The survey of one UAV: its own position, the load's, and each team member's as received
/// (capacity `N` UAVs; the own slot of `team` is unused, the own position is `own`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TakeoffSurvey<const N: usize> {
    window: u32,
    own: PositionMean,
    load: PositionMean,
    team: [PositionMean; N],
}

impl<const N: usize> TakeoffSurvey<N> {
    /// An empty survey averaging over `window` samples per source (1: the last sample only,
    /// the behaviour before the survey).
    #[must_use]
    pub const fn new(window: u32) -> Self {
        Self { window, own: PositionMean::new(), load: PositionMean::new(), team: [PositionMean::new(); N] }
    }

    /// Forgets every sample and sets the window (samples per source, >= 1).
    pub fn reset(&mut self, window: u32) {
        *self = Self::new(window);
    }

    /// The averaging window, samples per source.
    #[must_use]
    pub fn window(&self) -> u32 {
        self.window
    }

    /// The UAV's own position sample, m.
    pub fn push_own(&mut self, pos_m: &Vector3<f32>) {
        self.own.push(pos_m, self.window);
    }

    /// A load position sample, m.
    pub fn push_load(&mut self, pos_m: &Vector3<f32>) {
        self.load.push(pos_m, self.window);
    }

    /// Team member `j`'s position as received, m (ignored for `j >= N`).
    pub fn push_member(&mut self, j: usize, pos_m: &Vector3<f32>) {
        if let Some(m) = self.team.get_mut(j) {
            m.push(pos_m, self.window);
        }
    }

    /// The averaged own position, m.
    #[must_use]
    pub fn own(&self) -> Option<Vector3<f32>> {
        self.own.mean()
    }

    /// The averaged load position, m.
    #[must_use]
    pub fn load(&self) -> Option<Vector3<f32>> {
        self.load.mean()
    }

    /// Team member `j`'s averaged position, m.
    #[must_use]
    pub fn member(&self, j: usize) -> Option<Vector3<f32>> {
        self.team.get(j).and_then(PositionMean::mean)
    }

}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32, y: f32, z: f32) -> Vector3<f32> {
        Vector3::new(x, y, z)
    }

    #[test]
    fn exact_mean_within_the_window() {
        let mut m = PositionMean::new();
        assert_eq!(m.mean(), None);
        for k in 1..=4 {
            m.push(&v(k as f32, -(k as f32), 10.0), 8);
        }
        assert_eq!(m.mean(), Some(v(2.5, -2.5, 10.0)));
        assert_eq!(m.count(), 4);
    }

    #[test]
    fn window_one_is_the_last_sample() {
        let mut m = PositionMean::new();
        for k in 0..5 {
            m.push(&v(k as f32, 0.0, 0.0), 1);
        }
        assert_eq!(m.mean(), Some(v(4.0, 0.0, 0.0)));
        let mut z = PositionMean::new();
        z.push(&v(1.0, 2.0, 3.0), 0);
        z.push(&v(4.0, 5.0, 6.0), 0);
        assert_eq!(z.mean(), Some(v(4.0, 5.0, 6.0)), "window 0 counts as 1");
    }

    #[test]
    fn non_finite_samples_are_ignored() {
        let mut m = PositionMean::new();
        m.push(&v(1.0, 1.0, 1.0), 10);
        m.push(&v(f32::NAN, 0.0, 0.0), 10);
        m.push(&v(0.0, f32::INFINITY, 0.0), 10);
        assert_eq!(m.mean(), Some(v(1.0, 1.0, 1.0)));
        assert_eq!(m.count(), 1);
    }

    #[test]
    fn a_move_is_forgotten_after_the_window() {
        // Climb samples at z = 0 then hover at z = 10: after 10 windows the climb weighs
        // (1 - 1/w)^(10 w) < e^-10 of the mean.
        let w = 20;
        let mut m = PositionMean::new();
        for _ in 0..w {
            m.push(&v(0.0, 0.0, 0.0), w);
        }
        for _ in 0..10 * w {
            m.push(&v(0.0, 0.0, 10.0), w);
        }
        let z = m.mean().map_or(f32::NAN, |p| p.z);
        assert!((z - 10.0).abs() < 10.0 * 1e-4, "z {z}");
    }

    #[test]
    fn averaging_reduces_white_noise_as_one_over_sqrt_k() {
        // Deterministic pseudo-random noise (xorshift), uniform in [-a, a]: std a / sqrt(3).
        let mut s: u32 = 0x1234_5678;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            (s as f32 / u32::MAX as f32) * 2.0 - 1.0
        };
        let (a, k, trials) = (0.3f32, 100u32, 400);
        let mut sq = 0.0f64;
        for _ in 0..trials {
            let mut m = PositionMean::new();
            for _ in 0..k {
                m.push(&v(5.0 + a * next(), 0.0, 0.0), k);
            }
            let e = m.mean().map_or(f32::NAN, |p| p.x) - 5.0;
            sq += f64::from(e * e);
        }
        let rms = (sq / f64::from(trials)).sqrt();
        let single = f64::from(a) / 3f64.sqrt();
        let expected = single / f64::from(k).sqrt();
        assert!(rms < 1.3 * expected && rms > 0.7 * expected, "rms {rms} vs {expected} (single sample {single})");
    }

    #[test]
    fn survey_keeps_sources_apart() {
        let mut s = TakeoffSurvey::<4>::new(10);
        s.push_own(&v(1.0, 0.0, 0.0));
        s.push_load(&v(0.0, 0.0, -3.0));
        s.push_member(1, &v(2.0, 0.0, 0.0));
        s.push_member(1, &v(4.0, 0.0, 0.0));
        s.push_member(2, &v(0.0, 2.0, 0.0));
        s.push_member(9, &v(9.0, 9.0, 9.0));
        assert_eq!(s.own(), Some(v(1.0, 0.0, 0.0)));
        assert_eq!(s.load(), Some(v(0.0, 0.0, -3.0)));
        assert_eq!(s.member(1), Some(v(3.0, 0.0, 0.0)));
        assert_eq!(s.member(3), None);
        assert_eq!(s.member(9), None);
        s.reset(5);
        assert_eq!((s.own(), s.window()), (None, 5));
    }
}
