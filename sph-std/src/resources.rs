//! Resources checked before work: memory against what the machine has
//! available, so that a run too large for it is a clear error (exit 2,
//! with the estimate) instead of an allocation failure that aborts.

use crate::error::{Error, Result};

/// Bytes of memory available to this process: the smaller of the kernel's
/// `MemAvailable` and the cgroup's limit (where either is readable); `None`
/// where neither is (not Linux).
pub fn available_memory() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| {
        s.lines()
            .find(|l| l.starts_with("MemAvailable:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kb| kb.parse::<u64>().ok())
            .map(|kb| kb * 1024)
    });
    let cgroup = std::fs::read_to_string("/sys/fs/cgroup/memory.max")
        .ok()
        .and_then(|s| s.trim().parse::<u64>().ok());
    match (meminfo, cgroup) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// Refuses work estimated to need `bytes` of memory when the machine has
/// less available; `key` and `value` name the setting that decides the
/// size.
///
/// # Errors
/// [`Error::Config`] naming the setting, the estimate and what is available.
pub fn check_memory(key: &str, value: impl std::fmt::Display, bytes: f64) -> Result<()> {
    let Some(available) = available_memory() else {
        return Ok(());
    };
    if bytes.is_finite() && bytes <= available as f64 {
        return Ok(());
    }
    Err(Error::config(
        key,
        value,
        format!(
            "needs an estimated {} of memory, more than the {} available; reduce it",
            gib(bytes),
            gib(available as f64)
        ),
    ))
}

/// `bytes` in GiB (or MiB below one GiB), for messages.
pub fn gib(bytes: f64) -> String {
    const G: f64 = 1024.0 * 1024.0 * 1024.0;
    if !bytes.is_finite() {
        "an unbounded amount".to_string()
    } else if bytes >= G {
        format!("{:.1} GiB", bytes / G)
    } else {
        format!("{:.0} MiB", bytes / (1024.0 * 1024.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_impossible_size_is_refused_with_the_estimate() {
        if available_memory().is_none() {
            return;
        }
        let e = check_memory("n", 1e15, 1e18).unwrap_err().to_string();
        assert!(e.contains("`n`") && e.contains("GiB"), "{e}");
        assert!(check_memory("n", 10, 1e3).is_ok());
        assert!(check_memory("n", 10, f64::INFINITY).is_err());
    }
}
