//! Fault injection for tests of the recovery path: with `NURBS_CONTACT_FAIL_PROJECTION_AT=n` (or
//! `n-m`) in the environment, the `n`-th (to `m`-th) projection of all contact points of this
//! process (1-based, counting every [`crate::contact::ContactSystem::update`] that projects) fails
//! as a projection that finds no partner on any candidate element does. A single failure is
//! absorbed by the line search (a domain error shortens the Newton step); a run of them makes
//! Newton fail, and the load step must then be cut back and retried. `tests/contact.rs` runs a
//! case so. Unset (the default), this costs one atomic increment per projection of all points.
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

static CALLS: AtomicU64 = AtomicU64::new(0);
static AT: OnceLock<Option<(u64, u64)>> = OnceLock::new();

/// True when this projection of all points is the one to fail.
pub(crate) fn projection_fails() -> bool {
    let at = *AT.get_or_init(|| {
        let v = std::env::var("NURBS_CONTACT_FAIL_PROJECTION_AT").ok()?;
        let (a, b) = v.trim().split_once('-').unwrap_or((v.trim(), v.trim()));
        Some((a.parse().ok()?, b.parse().ok()?))
    });
    match at {
        None => false,
        Some((first, last)) => {
            let call = CALLS.fetch_add(1, Ordering::Relaxed) + 1;
            (first..=last).contains(&call)
        }
    }
}
