//! Stopping a study: the first SIGINT or SIGTERM to `study` is passed on to the runs in progress
//! (each `run`, or its `mpirun`, which passes it on to its ranks), so that they stop after their
//! load step; no further run starts, and once they have stopped the study writes its table and
//! exits with the signal's code. A run still going [`GRACE`] later, or at a second signal, is
//! killed with every process it started. Finished runs are kept: the study resumes when run again.

use signal_hook::consts::{SIGINT, SIGTERM};
use std::process::Command;
use std::sync::atomic::{AtomicI32, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// How long a run may take to stop after the signal was passed on to it.
pub const GRACE: Duration = Duration::from_secs(10);

/// The stop requests a study has received.
#[derive(Debug, Default)]
pub struct Stop {
    signal: AtomicI32,
    count: AtomicUsize,
}

impl Stop {
    /// Catches SIGINT and SIGTERM for this process from now on (a thread records them).
    pub fn install() -> std::io::Result<Arc<Stop>> {
        let stop = Arc::new(Stop::default());
        let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])?;
        let s = Arc::clone(&stop);
        std::thread::spawn(move || {
            for sig in signals.forever() {
                s.signal.store(sig, Ordering::SeqCst);
                s.count.fetch_add(1, Ordering::SeqCst);
            }
        });
        Ok(stop)
    }

    /// The signal received, if any.
    pub fn requested(&self) -> Option<i32> {
        (self.count.load(Ordering::SeqCst) > 0).then(|| self.signal.load(Ordering::SeqCst))
    }

    /// A second signal: the runs are to be killed at once.
    pub fn forced(&self) -> bool {
        self.count.load(Ordering::SeqCst) > 1
    }
}

/// The name `kill -s` takes for a stopping signal.
pub fn kill_name(signal: i32) -> &'static str {
    match signal {
        SIGINT => "INT",
        _ => "TERM",
    }
}

/// Sends `signal` (a `kill -s` name) to the process `pid`.
pub fn signal_process(pid: u32, signal: &str) {
    let _ = Command::new("kill")
        .args(["-s", signal, &pid.to_string()])
        .status();
}

/// Kills the process `pid` and every process it started, however deep (`mpirun`'s ranks sit in
/// process groups of their own): the tree is read from `/proc` before anything is killed.
pub fn kill_tree(pid: u32) {
    let mut all = vec![pid];
    let mut i = 0;
    let children = children_by_parent();
    while i < all.len() {
        if let Some(c) = children.get(&all[i]) {
            all.extend(c);
        }
        i += 1;
    }
    let mut cmd = Command::new("kill");
    cmd.args(["-s", "KILL", "--"]);
    cmd.args(all.iter().map(u32::to_string));
    let _ = cmd.stderr(std::process::Stdio::null()).status();
}

/// Every process's children, from the parent field of `/proc/<pid>/stat`.
fn children_by_parent() -> std::collections::HashMap<u32, Vec<u32>> {
    let mut map: std::collections::HashMap<u32, Vec<u32>> = Default::default();
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return map;
    };
    for e in dir.flatten() {
        let Some(pid) = e.file_name().to_str().and_then(|n| n.parse::<u32>().ok()) else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(e.path().join("stat")) else {
            continue;
        };
        // `pid (comm) state ppid ...`; comm may hold spaces and parentheses
        let ppid = stat
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().nth(1))
            .and_then(|p| p.parse::<u32>().ok());
        if let Some(ppid) = ppid {
            map.entry(ppid).or_default().push(pid);
        }
    }
    map
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kill_tree_ends_a_child_and_its_grandchild() {
        let mut child = Command::new("sh")
            .args(["-c", "sleep 30 & echo $!; wait"])
            .stdout(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let mut line = String::new();
        use std::io::BufRead;
        std::io::BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let grandchild: u32 = line.trim().parse().unwrap();
        kill_tree(child.id());
        let _ = child.wait();
        // reaped by init once killed; give it a moment
        let t0 = std::time::Instant::now();
        let alive = || {
            std::fs::read_to_string(format!("/proc/{grandchild}/stat")).is_ok_and(|s| {
                !s.rsplit_once(')')
                    .is_some_and(|(_, r)| r.trim_start().starts_with('Z'))
            })
        };
        while alive() && t0.elapsed() < std::time::Duration::from_secs(5) {
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        assert!(!alive(), "the grandchild {grandchild} survived");
    }
}
