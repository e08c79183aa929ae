//! An up-down timer: the time a condition has held, net of the time it has not (PX4's land
//! detector and hysteresis helpers count the same way). A condition that flickers, as a noisy
//! measurement around a threshold does, neither trips it nor resets it.

/// Net time a condition has held, s (never below 0).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Dwell {
    held_s: f32,
}

impl Dwell {
    /// Nothing held yet.
    pub const fn new() -> Self {
        Self { held_s: 0.0 }
    }

    /// Counts `dt_s` (s) up while `holds`, down otherwise (not below 0); a `dt_s` that is not
    /// finite and positive counts as 0. Returns the net time held, s.
    pub fn step(&mut self, holds: bool, dt_s: f32) -> f32 {
        let dt = if dt_s.is_finite() && dt_s > 0.0 { dt_s } else { 0.0 };
        self.held_s = if holds { self.held_s + dt } else { (self.held_s - dt).max(0.0) };
        self.held_s
    }

    /// The net time held so far, s.
    pub fn held_s(&self) -> f32 {
        self.held_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn it_counts_up_while_the_condition_holds_and_down_to_zero_otherwise() {
        let mut d = Dwell::default();
        assert_eq!(d.step(true, 0.5), 0.5);
        assert_eq!(d.step(true, 0.25), 0.75);
        assert_eq!(d.step(false, 0.5), 0.25);
        assert_eq!(d.step(false, 1.0), 0.0, "never below zero");
        for bad in [f32::NAN, f32::INFINITY, -1.0, 0.0] {
            assert_eq!(d.step(true, bad), 0.0, "{bad} counts as no time");
        }
        assert_eq!(d.held_s(), 0.0);
    }
}
