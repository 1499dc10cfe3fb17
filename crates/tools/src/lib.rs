//! Measurement probes of brachia's planner, solver and MPC; the library part holds what more than one
//! probe or test uses.
pub mod reach_box;
pub mod reach_interval;
pub mod reach_model;
pub mod reach_sweep;
pub mod reduced_two_link;
pub mod swing_dp;
