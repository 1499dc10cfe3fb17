//! IPOPT's filter (Waechter & Biegler 2006, section 2.3): pairs (theta, phi) of constraint
//! violation and barrier function that a trial point must improve on, with the upper limit
//! `theta_max` on the violation and the threshold `theta_min` below which the switching condition
//! applies.

/// The filter of one phase (the original problem or restoration).
#[derive(Debug, Default)]
pub(super) struct Filter {
    /// Entries (theta, phi); memory reserved once per solve ([`Filter::reserve`]).
    entries: Vec<(f64, f64)>,
    /// No trial point with a violation of `theta_max` or more is accepted.
    pub(super) theta_max: f64,
    /// Below `theta_min` an f-type step (switching condition and Armijo) is asked for.
    pub(super) theta_min: f64,
}

impl Filter {
    /// Makes room for `n` entries (a no-op once there is room).
    pub(super) fn reserve(&mut self, n: usize) {
        if self.entries.capacity() < n {
            self.entries.reserve(n);
        }
    }

    /// Empties the filter (the limits stay).
    pub(super) fn clear(&mut self) {
        self.entries.clear();
    }

    /// Sets the limits from the violation `theta` at the start of a phase: `theta_max =
    /// 1e4 max(theta_ref, 1)`, `theta_min = 1e-4 max(theta, 1)`.
    pub(super) fn set_limits(&mut self, theta_ref: f64, theta: f64) {
        self.theta_max = 1e4 * theta_ref.max(1.0);
        self.theta_min = 1e-4 * theta.max(1.0);
    }

    /// Whether (theta, phi) is acceptable to the filter (not dominated by an entry).
    pub(super) fn acceptable(&self, theta: f64, phi: f64) -> bool {
        self.entries.iter().all(|&(ft, fp)| theta < ft || phi < fp)
    }

    /// Adds (theta, phi), dropping the entries it dominates. The memory stays bounded: when the
    /// reserved room is full, the entry with the largest theta goes.
    pub(super) fn add(&mut self, theta: f64, phi: f64) {
        let filter = &mut self.entries;
        filter.retain(|&(ft, fp)| !(ft >= theta && fp >= phi));
        if filter.len() == filter.capacity() {
            if let Some((imax, _)) = filter
                .iter()
                .enumerate()
                .max_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
            {
                filter.swap_remove(imax);
            }
        }
        filter.push((theta, phi));
    }

    /// Copies the entries and limits of `other` (within the reserved room).
    pub(super) fn copy_from(&mut self, other: &Filter) {
        self.entries.clear();
        self.entries.extend_from_slice(&other.entries);
        self.theta_max = other.theta_max;
        self.theta_min = other.theta_min;
    }
}
