//! Forward-backward sweeps of the reachable-set bound ([`ReachBox`]): a tighter proof that no motion of
//! the relaxed two-link swing goes from a start set to a target set in a given time.
//!
//! A motion of `K` steps from the start to the target passes at every step `k` through a state that
//! the bound from the start holds at `k` and that the reversed bound from the target (time, `H` and the
//! elbow's rate reversed) holds at `K - k`. Meeting in the middle compares the two at one step only;
//! a sweep prunes the bound it steps with the other one's boxes at every step
//! ([`ReachBox::prune_reversed`]: each box cut to the hull of its intersections), so the part of a box
//! that no motion to the target can use is not carried on to grow:
//!
//! 1. the reversed bound from the target, unpruned, to step `K - K / 2`, every step kept;
//! 2. forward from the start to `K`, pruned at each step by the kept reversed bound where it has one;
//! 3. reversed from the target to `K`, pruned at each step by the forward sweep just made;
//! 4. forward again, pruned by that reversed sweep; and so on, alternating.
//!
//! By induction every motion from the start to the target stays in every kept bound; a sweep in
//! which some step holds no box proves that no such motion exists.
//!
//! Refinement: the sweeps of a coarse grid (a [`SweepOutcome`] passed as `prior`) prune every step
//! of the sweeps of a finer one (narrower `q2`, `z` and `H` cells; the same `dt` or a whole fraction
//! of it, each step at a time of the coarse grid pruned), from the
//! first step of the first sweep on, so the finer grid holds only the cells about the coarse one's
//! boxes: the grid is refined where the motions to the target could be, not everywhere. Sweeps stop at the proof, after
//! `passes`, or when a sweep leaves more than `stall` times the boxes of the previous one in the same
//! direction.
use crate::reach_box::{Grid, ReachBox, ReachError, ReachSettings, Snapshot};
use crate::reach_interval::Iv;
use crate::reduced_two_link::ReducedTwoLink;

/// Which way a sweep runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// From the start.
    Forward,
    /// From the target, reversed in time.
    Reversed,
}

/// What one sweep left.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PassStats {
    pub direction: Direction,
    /// The fewest boxes at any step (0: proven).
    pub least: usize,
    /// The step (in the sweep's own time) of the fewest boxes.
    pub least_at: usize,
    /// The boxes summed over every step.
    pub total: usize,
    /// The most boxes at any step.
    pub peak: usize,
    /// The boxes at the middle step (`K / 2` of the sweep's own time; 0 when it ended before).
    pub mid: usize,
}

/// The sweeps' result.
#[derive(Debug, Clone)]
pub struct SweepOutcome {
    /// Whether no motion of `K` steps goes from the start to the target.
    pub proven: bool,
    /// One entry per sweep, the unpruned reversed bound of step 1 first.
    pub passes: Vec<PassStats>,
    /// The last forward sweep's bound at every step `0..=K` (empty when a sweep proved it before any
    /// forward sweep ended).
    pub forward: Vec<Snapshot>,
    /// The last reversed sweep's bound at every step it reached.
    pub reversed: Vec<Snapshot>,
    /// The grid of the bounds.
    pub grid: Grid,
    /// The steps of the motion (`K`).
    pub steps: usize,
    /// The time step, s.
    pub dt: f64,
}

/// A store of bounds that prunes a sweep: the bound at every step, its grid, whether it runs in
/// the other direction (momentum reversed, indexed from the end) or the same.
struct Constraint<'a> {
    store: &'a [Snapshot],
    grid: Grid,
    other_direction: bool,
    /// Steps of the pruned sweep per step of the store (the store prunes every `ratio`-th step).
    ratio: usize,
}

/// The sweeps' settings.
#[derive(Debug, Clone, Copy)]
pub struct SweepSettings {
    /// Steps of the motion (`K`, the swing time over `dt`).
    pub steps: usize,
    /// Most sweeps after the first unpruned reversed bound.
    pub passes: usize,
    /// A sweep that keeps more than this fraction of the boxes of the previous sweep in the same
    /// direction ends the sweeps.
    pub stall: f64,
}

/// A bound from the union of `boxes` (`[q1, H, q2]`), with `H` reversed when `reversed`.
fn bound_from(
    model: &ReducedTwoLink,
    s: &ReachSettings,
    boxes: &[[Iv; 3]],
    reversed: bool,
) -> Result<ReachBox, ReachError> {
    let mut out: Option<ReachBox> = None;
    for b in boxes {
        let h = if reversed { -b[1] } else { b[1] };
        let rb = ReachBox::from_box(model, s, [b[0], h, b[2]])?;
        match out.as_mut() {
            Some(o) => o.absorb(rb)?,
            None => out = Some(rb),
        }
    }
    out.ok_or(ReachError::Setting("a start or target set holds no box"))
}

/// One sweep of `k_end` steps from `boxes`, pruned at step `k` by each constraint's bound at `k`
/// (same direction) or at `k_all - k` (the other direction) where it has one; every step kept.
fn run_pass(
    model: &ReducedTwoLink,
    s: &ReachSettings,
    boxes: &[[Iv; 3]],
    direction: Direction,
    (k_all, k_end): (usize, usize),
    cons: &[Constraint],
) -> Result<(PassStats, Vec<Snapshot>), ReachError> {
    let mut rb = bound_from(model, s, boxes, direction == Direction::Reversed)?;
    let mut kept = Vec::with_capacity(k_end + 1);
    let mut st = PassStats {
        direction,
        least: usize::MAX,
        least_at: 0,
        total: 0,
        peak: 0,
        mid: 0,
    };
    loop {
        let k = rb.steps();
        let mut n = rb.cells();
        for c in cons {
            let at = if c.other_direction {
                k_all.checked_sub(k)
            } else {
                Some(k)
            };
            let at = at
                .filter(|j| j.is_multiple_of(c.ratio))
                .map(|j| j / c.ratio);
            if let Some(o) = at.and_then(|j| c.store.get(j)) {
                n = rb.prune_by(o, &c.grid, c.other_direction);
            }
        }
        st.total += n;
        st.peak = st.peak.max(n);
        if k == k_all / 2 {
            st.mid = n;
        }
        if n < st.least {
            st.least = n;
            st.least_at = k;
        }
        kept.push(rb.snapshot());
        if n == 0 || k >= k_end {
            return Ok((st, kept));
        }
        rb.step()?;
    }
}

/// Sweep forward from `start` and reversed from `target` (both unions of `[q1, H, q2]` boxes, `H` as
/// the motion has it) over `sw.steps` steps of `s.dt`, each step pruned by `prior` (the sweeps of the
/// same start and target over the same time, on a grid with the same `q2` range and `dt` a whole
/// multiple of `s.dt`) too.
pub fn sweep(
    model: &ReducedTwoLink,
    s: &ReachSettings,
    start: &[[Iv; 3]],
    target: &[[Iv; 3]],
    sw: &SweepSettings,
    prior: Option<&SweepOutcome>,
) -> Result<SweepOutcome, ReachError> {
    let k = sw.steps;
    let ratio = match prior {
        Some(p) if p.steps == 0 || !k.is_multiple_of(p.steps) => return Err(ReachError::Setting(
            "a prior's steps must divide the sweep's steps (the same time, dt a whole multiple)",
        )),
        Some(p) => k / p.steps,
        None => 1,
    };
    if prior.is_some_and(|p| (p.dt - s.dt * ratio as f64).abs() > 1e-12 * p.dt) {
        return Err(ReachError::Setting(
            "a prior's dt must be the sweep's dt times the ratio of their steps (the same time)",
        ));
    }
    let prior_cons = |direction: Direction| -> Vec<Constraint> {
        let Some(p) = prior else { return vec![] };
        let (same, other) = match direction {
            Direction::Forward => (&p.forward, &p.reversed),
            Direction::Reversed => (&p.reversed, &p.forward),
        };
        vec![
            Constraint {
                store: same,
                grid: p.grid,
                other_direction: false,
                ratio,
            },
            Constraint {
                store: other,
                grid: p.grid,
                other_direction: true,
                ratio,
            },
        ]
    };
    // without a prior, the reversed bound to the middle; with one, pruned by it throughout
    let k_first = if prior.is_some() { k } else { k - k / 2 };
    let grid = bound_from(model, s, target, true)?.grid();
    let (st, rev) = run_pass(
        model,
        s,
        target,
        Direction::Reversed,
        (k, k_first),
        &prior_cons(Direction::Reversed),
    )?;
    let mut out = SweepOutcome {
        proven: st.least == 0,
        passes: vec![st],
        forward: vec![],
        reversed: rev,
        grid,
        steps: k,
        dt: s.dt,
    };
    if out.proven {
        return Ok(out);
    }
    let mut last = [usize::MAX; 2];
    for pass in 0..sw.passes {
        let direction = if pass % 2 == 0 {
            Direction::Forward
        } else {
            Direction::Reversed
        };
        // the sweep this one replaces prunes nothing now: freed before it runs
        let (boxes, store) = match direction {
            Direction::Forward => {
                out.forward = vec![];
                (start, &out.reversed)
            }
            Direction::Reversed => {
                out.reversed = vec![];
                (target, &out.forward)
            }
        };
        let mut cons = prior_cons(direction);
        cons.push(Constraint {
            store,
            grid,
            other_direction: true,
            ratio: 1,
        });
        let (st, kept) = run_pass(model, s, boxes, direction, (k, k), &cons)?;
        out.passes.push(st);
        match direction {
            Direction::Forward => out.forward = kept,
            Direction::Reversed => out.reversed = kept,
        }
        if st.least == 0 {
            out.proven = true;
            return Ok(out);
        }
        let d = pass % 2;
        let stalled = st.total as f64 > sw.stall * last[d] as f64;
        last[d] = st.total;
        if stalled {
            break;
        }
    }
    Ok(out)
}
