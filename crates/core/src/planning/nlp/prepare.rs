//! What both backends share: the problem's structure read once and checked ([`Prepared`]), its
//! callbacks guarded against panics and non-finite values ([`Evaluator`]), the passes counted
//! ([`Meter`]) and the outcome a backend hands back ([`BackendOutcome`]).

use std::time::Instant;

use super::problem::{NlpSettings, PassStats, SolveStatus, SparseNlp, TimeSplit, BACKEND_INF};

/// A fingerprint of one iteration's summary row, to recognise a row a backend sends again.
pub(crate) type IterFingerprint = [u64; 6];

/// Accumulator of one pass.
#[derive(Debug, Clone, Default)]
pub(crate) struct PassAcc {
    pub(crate) iterations: usize,
    pub(crate) seen_iteration: bool,
    pub(crate) split: TimeSplit,
    pub(crate) last_row: Option<IterFingerprint>,
}

/// Counts iterations and splits time by pass, from the callbacks and the per-iteration events of
/// a backend (see [`TimeSplit`] for the attribution).
#[derive(Debug, Clone)]
pub(crate) struct Meter {
    /// End of the last event (callback or iteration), or the start.
    pub(crate) last: Instant,
    /// The last callback was a Hessian evaluation.
    pub(crate) after_hessian: bool,
    /// Time since the last iteration event, not yet given to a pass.
    pub(crate) pending: TimeSplit,
    pub(crate) passes: Vec<PassAcc>,
    /// A pass whose final row the backend sent again to mark its point as the one returned.
    pub(crate) returned: Option<usize>,
}

impl Meter {
    pub(crate) fn new() -> Self {
        Meter {
            last: Instant::now(),
            after_hessian: false,
            pending: TimeSplit::default(),
            passes: vec![PassAcc::default()],
            returned: None,
        }
    }

    /// Give the solver time since the last event to the linear algebra or the rest.
    pub(crate) fn gap(&mut self, now: Instant) {
        let g = now.saturating_duration_since(self.last).as_secs_f64();
        if self.after_hessian {
            self.pending.linear_algebra_s += g;
        } else {
            self.pending.line_search_and_other_s += g;
        }
        self.last = now;
    }

    /// Run one callback, timing it.
    pub(crate) fn timed<R>(&mut self, hessian: bool, f: impl FnOnce() -> R) -> R {
        self.gap(Instant::now());
        let r = f();
        let end = Instant::now();
        self.pending.callbacks_s += end.saturating_duration_since(self.last).as_secs_f64();
        self.last = end;
        self.after_hessian = hessian;
        r
    }

    pub(crate) fn current(&mut self) -> &mut PassAcc {
        self.passes.last_mut().expect("a meter always has a pass")
    }

    pub(crate) fn fold_pending(&mut self) {
        let p = std::mem::take(&mut self.pending);
        self.current().split.add(&p);
    }

    /// The backend reports iteration `iter` of its current pass with the summary row `row`
    /// (`restoration`: a row of the restoration phase, whose counter continues the pass's). A regular
    /// iteration 0 after iterations starts a new pass; a row equal to the final row of an earlier
    /// pass (sent again by pounce when it keeps an earlier pass's point) marks that pass as
    /// returned and is not counted.
    pub fn iteration(&mut self, iter: usize, restoration: bool, row: IterFingerprint) {
        self.gap(Instant::now());
        self.after_hessian = false;
        let cur = self.passes.len() - 1;
        if iter > 0 {
            if let Some(k) = self.passes[..cur]
                .iter()
                .rposition(|p| p.last_row == Some(row))
            {
                self.returned = Some(k);
                self.fold_pending();
                return;
            }
        }
        if iter == 0 && !restoration && self.current().seen_iteration {
            self.passes.push(PassAcc::default());
            self.returned = None;
        }
        self.fold_pending();
        let p = self.current();
        p.iterations = p.iterations.max(iter);
        p.seen_iteration = true;
        p.last_row = Some(row);
    }

    /// Close the meter: per pass (iterations, time split, seen an iteration event), and the pass
    /// marked as returned, if any.
    pub(crate) fn finish(&mut self) -> (Vec<(usize, TimeSplit, bool)>, Option<usize>) {
        self.gap(Instant::now());
        self.fold_pending();
        let passes = self
            .passes
            .iter()
            .map(|p| (p.iterations, p.split, p.seen_iteration))
            .collect();
        (passes, self.returned)
    }
}

/// A Jacobian or Hessian sparsity pattern with duplicates merged (and, for the Hessian, every
/// diagonal entry present).
#[derive(Debug, Clone)]
pub(crate) struct Pattern {
    /// Unique rows, 0-based.
    pub rows: Vec<usize>,
    /// Unique columns, 0-based.
    pub cols: Vec<usize>,
    /// For each user triplet, its position in the unique list; `None` when the user pattern has
    /// no duplicates (identity map).
    pub(crate) map: Option<Vec<usize>>,
    /// Number of user triplets.
    pub raw_nnz: usize,
}

impl Pattern {
    /// Check the triplets and merge duplicates. `lower` requires `row >= col`.
    pub fn new(
        what: &str,
        rows: Vec<usize>,
        cols: Vec<usize>,
        n_rows: usize,
        n_cols: usize,
        lower: bool,
    ) -> std::result::Result<Pattern, String> {
        if rows.len() != cols.len() {
            return Err(format!(
                "{what} structure: {} rows but {} columns",
                rows.len(),
                cols.len()
            ));
        }
        if rows.len() > i32::MAX as usize {
            return Err(format!("{what} structure: too many entries"));
        }
        for (k, (&r, &c)) in rows.iter().zip(&cols).enumerate() {
            if r >= n_rows || c >= n_cols {
                return Err(format!(
                    "{what} structure entry {k}: ({r}, {c}) outside {n_rows} x {n_cols}"
                ));
            }
            if lower && r < c {
                return Err(format!(
                    "{what} structure entry {k}: ({r}, {c}) is in the upper triangle (need row >= col)"
                ));
            }
        }
        let raw_nnz = rows.len();
        let mut seen = std::collections::HashMap::with_capacity(raw_nnz);
        let mut map = Vec::with_capacity(raw_nnz);
        let (mut ur, mut uc) = (Vec::with_capacity(raw_nnz), Vec::with_capacity(raw_nnz));
        for (&r, &c) in rows.iter().zip(&cols) {
            let next = ur.len();
            let slot = *seen.entry((r, c)).or_insert(next);
            if slot == next {
                ur.push(r);
                uc.push(c);
            }
            map.push(slot);
        }
        if lower {
            // Every diagonal entry is made structural (zero-valued when the user has none): the
            // backends add their inertia-correcting shifts on the diagonal, and ripopt's faer
            // LDL^T cannot place a shift where the pattern has no entry (observed: a
            // `NumericalError` at iteration 0 on the double integrator, whose states have no
            // Hessian entries).
            let mut has_diag = vec![false; n_rows];
            for (&r, &c) in ur.iter().zip(&uc) {
                if r == c {
                    has_diag[r] = true;
                }
            }
            for (i, _) in has_diag.iter().enumerate().filter(|(_, &d)| !d) {
                ur.push(i);
                uc.push(i);
            }
        }
        let map = (ur.len() != raw_nnz).then_some(map);
        Ok(Pattern {
            rows: ur,
            cols: uc,
            map,
            raw_nnz,
        })
    }

    /// Number of unique entries (what the backends see).
    pub fn nnz(&self) -> usize {
        self.rows.len()
    }

    /// Sum the user's values `raw` (raw_nnz) into `out` (nnz; added diagonal entries get 0).
    pub(crate) fn merge(&self, raw: &[f64], out: &mut [f64]) {
        match &self.map {
            None => out.copy_from_slice(raw),
            Some(map) => {
                out.fill(0.0);
                for (&k, &v) in map.iter().zip(raw) {
                    out[k] += v;
                }
            }
        }
    }
}

/// Warm-start multipliers gathered from the problem.
#[derive(Debug, Clone)]
pub(crate) struct WarmStart {
    pub lambda: Vec<f64>,
    pub z_l: Vec<f64>,
    pub z_u: Vec<f64>,
}

/// Everything about the problem that is fixed during a solve, gathered and checked up front.
#[derive(Debug, Clone)]
pub(crate) struct Prepared {
    pub n: usize,
    pub m: usize,
    /// Bounds with infinities mapped to `+-BACKEND_INF`.
    pub x_l: Vec<f64>,
    pub x_u: Vec<f64>,
    pub g_l: Vec<f64>,
    pub g_u: Vec<f64>,
    /// User bounds as given (for the violation measure).
    pub(crate) raw_bounds: [Vec<f64>; 4],
    pub x0: Vec<f64>,
    pub warm: Option<WarmStart>,
    pub jac: Pattern,
    pub hess: Pattern,
}

pub(crate) fn to_backend_bound(b: f64) -> f64 {
    b.clamp(-BACKEND_INF, BACKEND_INF)
}

impl Prepared {
    pub(crate) fn new(
        nlp: &dyn SparseNlp,
        settings: &NlpSettings,
    ) -> std::result::Result<Prepared, String> {
        let (n, m) = (nlp.n_vars(), nlp.n_cons());
        if n == 0 {
            return Err("the problem has no variables".into());
        }
        if n > i32::MAX as usize || m > i32::MAX as usize {
            return Err(format!("too many variables or constraints ({n}, {m})"));
        }
        let (mut x_l, mut x_u) = (vec![f64::NEG_INFINITY; n], vec![f64::INFINITY; n]);
        let (mut g_l, mut g_u) = (vec![f64::NEG_INFINITY; m], vec![f64::INFINITY; m]);
        nlp.bounds(&mut x_l, &mut x_u, &mut g_l, &mut g_u);
        for (what, lo, hi) in [("x", &x_l, &x_u), ("g", &g_l, &g_u)] {
            for (i, (&l, &u)) in lo.iter().zip(hi.iter()).enumerate() {
                if l.is_nan() || u.is_nan() || l > u || l == f64::INFINITY || u == f64::NEG_INFINITY
                {
                    return Err(format!("bounds of {what}[{i}]: [{l}, {u}] is empty or NaN"));
                }
            }
        }
        let mut x0 = vec![0.0; n];
        nlp.initial_guess(&mut x0);
        if let Some(i) = x0.iter().position(|v| !v.is_finite()) {
            return Err(format!("initial guess x[{i}] = {} is not finite", x0[i]));
        }
        let warm = if settings.warm_start {
            let mut w = WarmStart {
                lambda: vec![0.0; m],
                z_l: vec![0.0; n],
                z_u: vec![0.0; n],
            };
            let ok = nlp.initial_multipliers(&mut w.lambda, &mut w.z_l, &mut w.z_u);
            let finite = w
                .lambda
                .iter()
                .chain(&w.z_l)
                .chain(&w.z_u)
                .all(|v| v.is_finite());
            (ok && finite).then_some(w)
        } else {
            None
        };
        let (jr, jc) = nlp.jacobian_structure();
        let jac = Pattern::new("Jacobian", jr, jc, m, n, false)?;
        let (hr, hc) = nlp.hessian_structure();
        let hess = Pattern::new("Hessian", hr, hc, n, n, true)?;
        let map = |v: &[f64]| v.iter().map(|&b| to_backend_bound(b)).collect::<Vec<_>>();
        Ok(Prepared {
            n,
            m,
            x_l: map(&x_l),
            x_u: map(&x_u),
            g_l: map(&g_l),
            g_u: map(&g_u),
            raw_bounds: [x_l, x_u, g_l, g_u],
            x0,
            warm,
            jac,
            hess,
        })
    }

    /// Largest bound violation of x and of g(x) = `g`.
    pub(crate) fn violation(&self, x: &[f64], g: &[f64]) -> f64 {
        let [x_l, x_u, g_l, g_u] = &self.raw_bounds;
        let viol = |v: &[f64], lo: &[f64], hi: &[f64]| {
            v.iter()
                .zip(lo.iter().zip(hi))
                .map(|(&v, (&l, &u))| {
                    if v.is_nan() {
                        f64::INFINITY
                    } else {
                        (l - v).max(v - u).max(0.0)
                    }
                })
                .fold(0.0, f64::max)
        };
        viol(x, x_l, x_u).max(viol(g, g_l, g_u))
    }
}

/// Calls into the user's problem for the backends: merges duplicate triplets and turns non-finite
/// values into evaluation failures (`false` / `None`).
pub(crate) struct Evaluator<'a> {
    pub(crate) nlp: &'a mut dyn SparseNlp,
    pub(crate) prep: &'a Prepared,
    pub(crate) jac_raw: Vec<f64>,
    pub(crate) hess_raw: Vec<f64>,
    /// Iterations and time by pass.
    pub meter: Meter,
}

pub(crate) fn all_finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

impl<'a> Evaluator<'a> {
    pub fn new(nlp: &'a mut dyn SparseNlp, prep: &'a Prepared) -> Self {
        Evaluator {
            nlp,
            prep,
            jac_raw: vec![0.0; prep.jac.raw_nnz],
            hess_raw: vec![0.0; prep.hess.raw_nnz],
            meter: Meter::new(),
        }
    }

    /// f(x), or `None` if it is not finite.
    pub fn objective(&mut self, x: &[f64]) -> Option<f64> {
        let nlp = &mut *self.nlp;
        let f = self.meter.timed(false, || nlp.objective(x));
        f.is_finite().then_some(f)
    }

    /// Gradient into `out` (n).
    pub fn gradient(&mut self, x: &[f64], out: &mut [f64]) -> bool {
        let nlp = &mut *self.nlp;
        self.meter.timed(false, || nlp.gradient(x, out));
        all_finite(out)
    }

    /// g(x) into `out` (m).
    pub fn constraints(&mut self, x: &[f64], out: &mut [f64]) -> bool {
        let nlp = &mut *self.nlp;
        self.meter.timed(false, || nlp.constraints(x, out));
        all_finite(out)
    }

    /// Merged Jacobian values into `out` (unique nnz).
    pub fn jacobian(&mut self, x: &[f64], out: &mut [f64]) -> bool {
        let (nlp, raw, prep) = (&mut *self.nlp, &mut self.jac_raw, self.prep);
        self.meter.timed(false, || {
            raw.fill(0.0);
            nlp.jacobian_values(x, raw);
            prep.jac.merge(raw, out);
        });
        all_finite(out)
    }

    /// Merged Hessian-of-the-Lagrangian values into `out` (unique nnz).
    pub fn hessian(&mut self, x: &[f64], obj_factor: f64, lambda: &[f64], out: &mut [f64]) -> bool {
        let (nlp, raw, prep) = (&mut *self.nlp, &mut self.hess_raw, self.prep);
        self.meter.timed(true, || {
            raw.fill(0.0);
            nlp.hessian_values(x, obj_factor, lambda, raw);
            prep.hess.merge(raw, out);
        });
        all_finite(out)
    }

    /// The passes of the backend's run, labelled `first` (the first pass) and `resolve` (any
    /// later one), with `iterations` (the backend's own count) standing in for a backend that
    /// reported no iteration events. `status` goes to the returned pass: the one marked by
    /// [`Meter::iteration`], else the last.
    pub fn passes(
        &mut self,
        first: &str,
        resolve: &str,
        iterations: usize,
        status: &SolveStatus,
    ) -> Vec<PassStats> {
        let (raw, marked) = self.meter.finish();
        let seen_any = raw.iter().any(|p| p.2);
        let returned = marked.unwrap_or(raw.len() - 1);
        raw.iter()
            .enumerate()
            .map(|(k, &(it, split, _))| PassStats {
                what: if k == 0 { first } else { resolve }.to_string(),
                iterations: if seen_any { it } else { iterations },
                time_s: split.total_s(),
                time: split,
                status: (k == returned).then(|| status.clone()),
                returned: k == returned,
            })
            .collect()
    }
}

/// What a backend hands back to [`solve`].
#[derive(Debug, Clone)]
pub(crate) struct BackendOutcome {
    pub status: SolveStatus,
    pub backend_status: String,
    /// Final iterate, if the backend produced one.
    pub x: Option<Vec<f64>>,
    pub lambda: Option<Vec<f64>>,
    pub z_l: Option<Vec<f64>>,
    pub z_u: Option<Vec<f64>>,
    /// Iterations over every pass.
    pub iterations: usize,
    /// Every pass (see [`Evaluator::passes`]); empty when the backend could not start.
    pub passes: Vec<PassStats>,
}

impl BackendOutcome {
    /// A backend that panicked: no iterate, no iterations, the passes it recorded.
    pub(crate) fn panicked(status: SolveStatus, passes: Vec<PassStats>) -> Self {
        BackendOutcome {
            status,
            backend_status: "panic".into(),
            x: None,
            lambda: None,
            z_l: None,
            z_u: None,
            iterations: 0,
            passes,
        }
    }
}

/// Text of a caught panic payload.
pub(crate) fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "non-string panic payload".to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planning::nlp::{Backend, MuStrategy};

    #[test]
    fn the_meter_tells_passes_apart_and_recognises_a_row_sent_again() {
        let row = |i: u64, f: f64| [i, f.to_bits(), 0, 0, 0, 0];
        let mut m = Meter::new();
        for i in 0..=7 {
            m.iteration(i, false, row(i as u64, 1.0 / (1.0 + i as f64)));
        }
        // restoration rows continue the counter and do not start a pass, even at 0
        m.iteration(0, true, row(0, 9.0));
        m.iteration(8, true, row(8, 9.0));
        // a re-solve from iteration 0
        for i in 0..=5 {
            m.iteration(i, false, row(i as u64, 2.0 + i as f64));
        }
        let (passes, returned) = m.clone().finish();
        assert_eq!(
            passes.iter().map(|p| p.0).collect::<Vec<_>>(),
            [8, 5],
            "iterations per pass"
        );
        assert_eq!(returned, None, "no pass marked: the last is returned");
        // the backend sends the first pass's final row again: its point is the one returned
        m.iteration(8, true, row(8, 9.0));
        let (passes, returned) = m.finish();
        assert_eq!(passes.iter().map(|p| p.0).collect::<Vec<_>>(), [8, 5]);
        assert_eq!(returned, Some(0));
    }

    #[test]
    fn pattern_merges_duplicates_and_sums_values() {
        let p = Pattern::new("J", vec![0, 1, 0, 1], vec![2, 0, 2, 1], 2, 3, false).unwrap();
        assert_eq!(p.nnz(), 3);
        assert_eq!(p.rows, vec![0, 1, 1]);
        assert_eq!(p.cols, vec![2, 0, 1]);
        let mut out = [0.0; 3];
        p.merge(&[1.0, 2.0, 10.0, 3.0], &mut out);
        assert_eq!(out, [11.0, 2.0, 3.0]);
    }

    #[test]
    fn hessian_pattern_gets_a_structural_diagonal() {
        // 3 x 3 lower triangle with only (2, 0) and (1, 1): (0, 0) and (2, 2) are added as zeros.
        let p = Pattern::new("H", vec![2, 1], vec![0, 1], 3, 3, true).unwrap();
        assert_eq!(p.rows, vec![2, 1, 0, 2]);
        assert_eq!(p.cols, vec![0, 1, 0, 2]);
        let mut out = [f64::NAN; 4];
        p.merge(&[5.0, 7.0], &mut out);
        assert_eq!(out, [5.0, 7.0, 0.0, 0.0]);
    }

    #[test]
    fn pattern_rejects_upper_triangle_and_out_of_range() {
        assert!(Pattern::new("H", vec![0], vec![1], 2, 2, true).is_err());
        assert!(Pattern::new("J", vec![2], vec![0], 2, 2, false).is_err());
        assert!(Pattern::new("J", vec![0, 1], vec![0], 2, 2, false).is_err());
        assert!(Pattern::new("H", vec![1], vec![0], 2, 2, true).is_ok());
    }

    #[test]
    fn settings_default_validate_and_round_trip() {
        let s = NlpSettings::default();
        s.validate().unwrap();
        let text = toml::to_string(&s).unwrap();
        let back: NlpSettings = toml::from_str(&text).unwrap();
        assert_eq!(back, s);
        let r: NlpSettings =
            toml::from_str("backend = \"ripopt\"\nmu_strategy = \"adaptive\"").unwrap();
        assert_eq!(r.backend, Backend::Ripopt);
        assert_eq!(r.mu_strategy, MuStrategy::Adaptive);
        assert_eq!(r.max_iter, 500);
        assert_eq!(r.mu_init, None);
        let m: NlpSettings = toml::from_str("mu_init = 1e-4").unwrap();
        assert_eq!(m.mu_init, Some(1e-4));
        assert!(toml::from_str::<NlpSettings>("backend = \"ipopt\"").is_err());
        for bad in [
            NlpSettings {
                tol: 0.0,
                ..s.clone()
            },
            NlpSettings {
                constr_viol_tol: f64::NAN,
                ..s.clone()
            },
            NlpSettings {
                max_wall_time_s: Some(-1.0),
                ..s.clone()
            },
            NlpSettings {
                print_level: 13,
                ..s.clone()
            },
            NlpSettings {
                mu_init: Some(0.0),
                ..s.clone()
            },
            NlpSettings {
                tol: 1e308,
                ..s.clone()
            },
            NlpSettings {
                constr_viol_tol: 0.03,
                ..s.clone()
            },
            NlpSettings {
                acceptable_tol: 1.0,
                ..s.clone()
            },
        ] {
            assert!(bad.validate().is_err(), "{bad:?} should be rejected");
        }
        // the largest tolerance is accepted, and the message names the rule
        let edge = NlpSettings {
            tol: crate::limits::MAX_SOLVER_TOL,
            ..s.clone()
        };
        assert!(edge.validate().is_ok());
        let e = NlpSettings {
            tol: 0.5,
            ..s.clone()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("tol") && e.contains("MAX_SOLVER_TOL"), "{e}");
    }
}
