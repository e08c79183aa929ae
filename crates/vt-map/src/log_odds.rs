//! Log-odds occupancy: the sensor model and the clamped, saturating cell update.
//!
//! A cell stores `l = 16 ln(p / (1 - p))` as an `i8` (units of 1/16 nat): `0` is p = 0.5
//! (never observed, or evidence that cancelled out), positive is occupied, negative free.
//! A beam adds [`LogOddsParams::hit`] to the cell holding its end point and
//! [`LogOddsParams::miss`] to the cells it crosses; the result is clamped to
//! `[min, max]` (Hornung et al., "OctoMap: an efficient probabilistic 3D mapping framework
//! based on octrees", Autonomous Robots 34, 2013, eq. 2 and the clamping of section 3.2).
//! Clamping bounds the evidence a cell can hold, so a cell that was occupied becomes free again
//! when the obstacle leaves: from `max`, `floor(max / |miss|) + 1` misses (9 with the default).

use crate::MapError;

/// Log-odds units per nat: a cell holds `LOG_ODDS_PER_NAT * ln(p / (1 - p))`.
pub const LOG_ODDS_PER_NAT: f32 = 16.0;

/// The sensor model and clamping bounds, in log-odds units (1/16 nat).
///
/// The [`Default`] is OctoMap's (Hornung et al. 2013, section 5): p_hit 0.7 (+0.85 nat, +14),
/// p_miss 0.4 (-0.41 nat, -7), clamping at p 0.12 (-2.0 nat, -32) and 0.97 (+3.5 nat, +56);
/// each magnitude rounded up ([`LogOddsParams::from_probabilities`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LogOddsParams {
    /// Added to the cell holding a beam's end point (> 0), 1/16 nat.
    pub hit: i8,
    /// Added to each cell a beam crosses before its end (< 0), 1/16 nat.
    pub miss: i8,
    /// Lower clamp (< 0), 1/16 nat.
    pub min: i8,
    /// Upper clamp (> 0), 1/16 nat.
    pub max: i8,
}

/// OctoMap's hit log-odds, 1/16 nat (p_hit 0.7).
const OCTOMAP_HIT: i8 = 14;
/// OctoMap's miss log-odds, 1/16 nat (p_miss 0.4).
const OCTOMAP_MISS: i8 = -7;
/// OctoMap's lower clamp, 1/16 nat (p 0.12).
const OCTOMAP_MIN: i8 = -32;
/// OctoMap's upper clamp, 1/16 nat (p 0.97).
const OCTOMAP_MAX: i8 = 56;

impl LogOddsParams {
    /// OctoMap's sensor model and clamps (the default), usable in `const` context.
    pub const OCTOMAP: Self = Self {
        hit: OCTOMAP_HIT,
        miss: OCTOMAP_MISS,
        min: OCTOMAP_MIN,
        max: OCTOMAP_MAX,
    };
}

impl Default for LogOddsParams {
    fn default() -> Self {
        Self::OCTOMAP
    }
}

impl LogOddsParams {
    /// Checked constructor, 1/16 nat.
    ///
    /// # Errors
    /// [`MapError::BadParams`] unless `hit > 0`, `miss < 0`, `min < 0 < max`.
    pub fn new(hit: i8, miss: i8, min: i8, max: i8) -> Result<Self, MapError> {
        let p = Self {
            hit,
            miss,
            min,
            max,
        };
        p.check().map(|()| p)
    }

    /// From probabilities (each in `(0, 1)`): `16 ln(p / (1 - p))`, magnitude rounded up.
    ///
    /// # Errors
    /// [`MapError::BadParams`] when a probability is outside `(0, 1)`, its log-odds outside
    /// the `i8` range, or the result fails [`LogOddsParams::new`].
    pub fn from_probabilities(
        p_hit: f32,
        p_miss: f32,
        p_min: f32,
        p_max: f32,
    ) -> Result<Self, MapError> {
        Self::new(
            units_of(p_hit, "p_hit")?,
            units_of(p_miss, "p_miss")?,
            units_of(p_min, "p_min")?,
            units_of(p_max, "p_max")?,
        )
    }

    /// Whether `hit > 0`, `miss < 0` and `min < 0 < max`.
    pub fn is_valid(&self) -> bool {
        self.check().is_ok()
    }

    /// `Ok` when valid ([`LogOddsParams::new`]'s checks).
    pub(crate) fn check(&self) -> Result<(), MapError> {
        let bad = |field| Err(MapError::BadParams { field });
        if self.hit <= 0 {
            bad("hit")
        } else if self.miss >= 0 {
            bad("miss")
        } else if self.min >= 0 {
            bad("min")
        } else if self.max <= 0 {
            bad("max")
        } else {
            Ok(())
        }
    }

    /// `cell + delta`, saturating, then clamped to `[min, max]` (valid params assumed; with
    /// invalid ones the result is still some `i8`, never a panic).
    pub fn apply(&self, cell: i8, delta: i8) -> i8 {
        cell.saturating_add(delta).max(self.min).min(self.max)
    }
}

/// Occupancy probability of a log-odds value (1/16 nat): `1 - 1 / (1 + exp(l / 16))`.
pub fn probability(log_odds: i8) -> f32 {
    1.0 - 1.0 / (1.0 + libm::expf(f32::from(log_odds) / LOG_ODDS_PER_NAT))
}

/// `16 ln(p / (1 - p))`, magnitude rounded up, as `i8`.
fn units_of(p: f32, field: &'static str) -> Result<i8, MapError> {
    if !(p > 0.0 && p < 1.0) {
        return Err(MapError::BadParams { field });
    }
    let l = LOG_ODDS_PER_NAT * libm::logf(p / (1.0 - p));
    let rounded = if l < 0.0 {
        libm::floorf(l)
    } else {
        libm::ceilf(l)
    };
    if rounded >= f32::from(i8::MIN) && rounded <= f32::from(i8::MAX) {
        Ok(rounded as i8)
    } else {
        Err(MapError::BadParams { field })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_octomaps_figures() {
        let d = LogOddsParams::default();
        assert_eq!(
            LogOddsParams::from_probabilities(0.7, 0.4, 0.12, 0.97),
            Ok(d)
        );
        assert_eq!((d.hit, d.miss, d.min, d.max), (14, -7, -32, 56));
        assert!((probability(d.hit) - 0.7).abs() < 0.01);
        assert!((probability(d.max) - 0.97).abs() < 0.005);
        assert_eq!(probability(0), 0.5);
    }

    #[test]
    fn invalid_params_are_rejected() {
        assert_eq!(
            LogOddsParams::new(0, -7, -32, 56),
            Err(MapError::BadParams { field: "hit" })
        );
        assert_eq!(
            LogOddsParams::new(14, 0, -32, 56),
            Err(MapError::BadParams { field: "miss" })
        );
        assert_eq!(
            LogOddsParams::new(14, -7, 1, 56),
            Err(MapError::BadParams { field: "min" })
        );
        assert_eq!(
            LogOddsParams::new(14, -7, -32, -1),
            Err(MapError::BadParams { field: "max" })
        );
        assert!(LogOddsParams::from_probabilities(f32::NAN, 0.4, 0.12, 0.97).is_err());
        assert!(LogOddsParams::from_probabilities(0.7, 0.4, 0.12, 1.0).is_err());
        assert!(LogOddsParams::from_probabilities(0.7, 0.4, 1e-6, 0.97).is_err());
        // -221 < i8::MIN
    }

    #[test]
    fn apply_saturates_and_clamps() {
        let p = LogOddsParams::default();
        assert_eq!(p.apply(50, p.hit), 56);
        assert_eq!(p.apply(-30, p.miss), -32);
        let wide = LogOddsParams::new(127, -128, -128, 127).unwrap();
        assert_eq!(wide.apply(120, 127), 127);
        assert_eq!(wide.apply(-120, -128), -128);
        let inverted = LogOddsParams {
            hit: 1,
            miss: -1,
            min: 10,
            max: -10,
        };
        let _ = inverted.apply(0, 1); // defined, never a panic
    }
}
