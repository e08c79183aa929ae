//! Tests of the rigid-body quadrotor.
