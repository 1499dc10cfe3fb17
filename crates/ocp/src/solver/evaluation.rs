//! Calls into the problem: values and first derivatives at the iterate or a trial point, and the
//! Hessians of the Lagrangian; a panicking or non-finite callback becomes an error message.

use crate::problem::{EvalLevel, Multipliers, OcpProblem, Primal, StageEval, TerminalEval};
use crate::settings::OcpStats;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

/// Whether every entry of `v` is finite.
pub(super) fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// The message of a caught panic.
pub(super) fn panic_message(e: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = e.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = e.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".to_string()
    }
}

/// Evaluates `p` at `z` and checks that every value it wrote is finite; adds the time to the
/// evaluation time of `stats`.
pub(super) fn evaluate(
    p: &mut dyn OcpProblem,
    z: &Primal,
    level: EvalLevel,
    ev: &mut [StageEval],
    term: &mut TerminalEval,
    stats: &mut OcpStats,
) -> Result<(), String> {
    let t = Instant::now();
    let r = check_evaluation(p, z, level, ev, term);
    stats.time.evaluation_s += t.elapsed().as_secs_f64();
    r
}

fn check_evaluation(
    p: &mut dyn OcpProblem,
    z: &Primal,
    level: EvalLevel,
    ev: &mut [StageEval],
    term: &mut TerminalEval,
) -> Result<(), String> {
    let r = catch_unwind(AssertUnwindSafe(|| p.evaluate(z, level, ev, term)));
    match r {
        Err(e) => return Err(format!("evaluate panicked: {}", panic_message(&*e))),
        Ok(Err(e)) => return Err(e.to_string()),
        Ok(Ok(())) => {}
    }
    for (k, e) in ev.iter().enumerate() {
        let ok = e.cost.is_finite()
            && finite(&e.f)
            && finite(&e.c)
            && (level == EvalLevel::Values
                || (finite(&e.grad) && finite(&e.jac_f) && finite(&e.jac_c)));
        if !ok {
            return Err(format!("non-finite value at stage {k}"));
        }
    }
    if !finite(&term.r) || (level == EvalLevel::FirstOrder && !finite(&term.jac_r)) {
        return Err("non-finite terminal value".to_string());
    }
    Ok(())
}

/// The Hessians of the Lagrangian at `z` with multipliers `mult` and objective weight `sigma`
/// into `ev`; adds the time to the Hessian time of `stats`.
pub(super) fn hessians(
    p: &mut dyn OcpProblem,
    z: &Primal,
    sigma: f64,
    mult: &Multipliers,
    ev: &mut [StageEval],
    stats: &mut OcpStats,
) -> Result<(), String> {
    let t = Instant::now();
    let r = catch_unwind(AssertUnwindSafe(|| p.hessians(z, sigma, mult, ev)));
    stats.time.hessian_s += t.elapsed().as_secs_f64();
    let err = match r {
        Err(e) => Some(format!("hessians panicked: {}", panic_message(&*e))),
        Ok(Err(e)) => Some(e.to_string()),
        Ok(Ok(())) => ev
            .iter()
            .position(|e| !finite(&e.hess))
            .map(|k| format!("non-finite Hessian at stage {k}")),
    };
    err.map_or(Ok(()), Err)
}
