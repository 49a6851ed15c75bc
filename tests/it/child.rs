//! Runs the `quaketwin` binary as a child process with a time limit and
//! reports what the whole command did: exit code or signal, output, wall
//! time and the child's own peak resident memory.
//!
//! The peak is the `VmHWM` of `/proc/PID/status`, read every 5 ms while the
//! child runs (the last reading before it exits; the binary's allocator
//! keeps freed memory, so a late peak stays visible until then).  Not
//! `wait4`'s `ru_maxrss`: Linux carries the high-water mark of the forked
//! copy of *this* process across `exec` into it, so a child of a test
//! process holding 3 GB reports 3 GB however little it uses.
//!
//! Tests of whole commands use it to assert "exit 2 naming the key, within
//! T seconds and M megabytes" (issue 33): a usage error must come before
//! any allocation sized from the bad number, so a memory bound is the
//! observable difference between a checked and an unchecked parameter.

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// What a finished (or killed) child did.
#[derive(Debug)]
pub struct Outcome {
    /// Exit code; None when it ended by a signal or was killed at the limit.
    pub code: Option<i32>,
    /// The signal that ended it, if any (6 = abort, 9 = killed at the limit).
    pub signal: Option<i32>,
    /// Whether it was still running at the time limit (then killed).
    pub timed_out: bool,
    pub stdout: String,
    pub stderr: String,
    pub elapsed: Duration,
    /// Peak resident set of the child, bytes (see the module doc).
    pub peak_bytes: u64,
}

impl Outcome {
    /// One line for assertion messages.
    pub fn describe(&self) -> String {
        format!(
            "code {:?} signal {:?} timed_out {} in {:.2} s, peak {} MB, {} bytes on stdout; stderr: {}",
            self.code,
            self.signal,
            self.timed_out,
            self.elapsed.as_secs_f64(),
            self.peak_bytes >> 20,
            self.stdout.len(),
            self.stderr.chars().take(600).collect::<String>()
        )
    }
    /// Ended by itself with one of the documented exit codes (0, 1, 2).
    pub fn clean_exit(&self) -> bool {
        !self.timed_out && matches!(self.code, Some(0..=2))
    }
}

/// The binary under test.
pub fn binary() -> &'static Path {
    Path::new(env!("CARGO_BIN_EXE_quaketwin"))
}

/// Runs `quaketwin ARGS` in `dir` (stdin closed), killing it at `limit`.
pub fn run_quaketwin(args: &[&std::ffi::OsStr], dir: &Path, limit: Duration) -> Outcome {
    let mut cmd = Command::new(binary());
    cmd.args(args).current_dir(dir);
    run_limited(cmd, limit)
}

/// The high-water mark of the resident memory of process `pid`, kB (None
/// once it has exited).
fn vm_hwm_kb(pid: libc::pid_t) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Runs `cmd` with stdout/stderr captured (read on threads, so a chatty
/// child never blocks on a full pipe) and `limit` of wall time.
pub fn run_limited(mut cmd: Command, limit: Duration) -> Outcome {
    let start = Instant::now();
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn the child");
    let pid = child.id() as libc::pid_t;
    let drain = |r: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut buf = Vec::new();
            if let Some(mut r) = r {
                // Keep at most 1 MiB: a runaway writer must not fill the test's memory.
                let _ = r.by_ref().take(1 << 20).read_to_end(&mut buf);
                let _ = std::io::copy(&mut r, &mut std::io::sink());
            }
            String::from_utf8_lossy(&buf).into_owned()
        })
    };
    let out = drain(
        child
            .stdout
            .take()
            .map(|s| Box::new(s) as Box<dyn Read + Send>),
    );
    let err = drain(
        child
            .stderr
            .take()
            .map(|s| Box::new(s) as Box<dyn Read + Send>),
    );
    let mut timed_out = false;
    let mut peak_kb = 0u64;
    let (status, _usage) = loop {
        peak_kb = peak_kb.max(vm_hwm_kb(pid).unwrap_or(0));
        let mut status: libc::c_int = 0;
        // SAFETY: plain syscall on our own child's pid with valid out-pointers.
        let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
        let r = unsafe { libc::wait4(pid, &mut status, libc::WNOHANG, &mut usage) };
        if r == pid {
            break (status, usage);
        }
        assert!(r == 0, "wait4 failed: {}", std::io::Error::last_os_error());
        if start.elapsed() > limit && !timed_out {
            timed_out = true;
            // SAFETY: signal to our own child, not yet reaped.
            unsafe { libc::kill(pid, libc::SIGKILL) };
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    // The child is reaped by wait4: keep std from waiting on it again.
    std::mem::forget(child);
    let elapsed = start.elapsed();
    let (code, signal) = if libc::WIFEXITED(status) {
        (Some(libc::WEXITSTATUS(status)), None)
    } else if libc::WIFSIGNALED(status) {
        (None, Some(libc::WTERMSIG(status)))
    } else {
        (None, None)
    };
    Outcome {
        code,
        signal,
        timed_out,
        stdout: out.join().unwrap_or_default(),
        stderr: err.join().unwrap_or_default(),
        elapsed,
        peak_bytes: peak_kb * 1024,
    }
}
