//! Health of one control step, shared by the observer and the velocity loop.

/// What happened in the last `update`, ordered by severity (`Ok` < ... < `InvalidInput`).
///
/// When several apply, the most severe is reported (`core::cmp::max`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Status {
    /// Nominal step.
    #[default]
    Ok,
    /// The thrust demand was clamped to the thrust or tilt limit (integrator held on the
    /// saturated axes).
    Saturated,
    /// The observer re-seeded its velocity estimate on the measurement: the step was longer
    /// than its stability bound, an earlier input was skipped, or its state went non-finite.
    ObserverReset,
    /// An input was NaN or infinite, or `dt_s <= 0`: the observer skipped the step and the
    /// velocity loop flew its failsafe.
    InvalidInput,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn severity_orders_invalid_input_highest() {
        assert!(Status::Ok < Status::Saturated);
        assert!(Status::Saturated < Status::ObserverReset);
        assert!(Status::ObserverReset < Status::InvalidInput);
        assert_eq!(
            core::cmp::max(Status::Saturated, Status::Ok),
            Status::Saturated
        );
        assert_eq!(Status::default(), Status::Ok);
    }
}
