//! Seeded mutation fuzzing of every reader, the event manifest (through the
//! event-folder loader, zips included), twin files and design files (issue 14,
//! item 8).  Each case mutates a real seed input — truncation, bit flips, byte
//! insertion and deletion, extreme numbers in header fields, digit runs,
//! extreme binary integers, repeated chunks — and asserts:
//!
//! - no panic (`catch_unwind`);
//! - `Ok`, or an error that names the file and is not a usage error (bad data
//!   exits 1, docs/cli.md);
//! - bounded memory: the bytes live on the case's thread never exceed
//!   [`PEAK_BOUND`] (a counting global allocator in this test binary; the inputs
//!   are at most a few hundred kB, so more means a header count was trusted);
//! - bounded time: no case over [`SLOW_CASE`].
//!
//! Seeds: small inputs made from `sample-records/` (AT2, CSV, MCAP, the event
//! manifest, twin and design files); the tests with `shared` in their name
//! also use the real records of `../shared/records` (COSMOS, CSMIP V1/V2,
//! SMC, GeoNet, SAC, MiniSEED + StationXML, Xsens CSV), read in place, never
//! copied.  Cases are deterministic: case `i` of seed `s` is mutated by a
//! generator seeded from (`s`, `i`), so a failure names what to replay.
//!
//! The long run (docs/robustness.md):
//! `QUAKETWIN_FUZZ_CASES=1000000 cargo test --release --test it fuzz_long_run -- --ignored --nocapture`
//! (`QUAKETWIN_FUZZ_SAVE=DIR` keeps every failing input).
//!
//! The same seeds start the cargo-fuzz targets of `fuzz/`
//! ([`fuzz_cargo_fuzz_corpus_shared`], run by `scripts/fuzz-corpus.sh`).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::io::{Cursor, Write};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use quaketwin::design::file::{load_design, MotionSource};
use quaketwin::design::motion::base_motion_from_event;
use quaketwin::event_folder;
use quaketwin::readers::{self, stationxml, Format, ReadOptions};
use quaketwin::rng::SplitMix64;
use quaketwin::sinks::mcap_writer::{self, McapWriteOptions};
use quaketwin::vocab::{Event, SourceRef};

// ---------------------------------------------------------------------------
// Counting allocator: live bytes and their peak, per thread.

struct Counting;

#[global_allocator]
static ALLOCATOR: Counting = Counting;

thread_local! {
    static LIVE: Cell<i64> = const { Cell::new(0) };
    static PEAK: Cell<i64> = const { Cell::new(0) };
    /// (seed label, case) of the fuzz case running on this thread, if any.
    static CASE: Cell<Option<(&'static str, u64)>> = const { Cell::new(None) };
}

/// Most bytes a case may hold at once.
const PEAK_BOUND: i64 = 256 << 20;
/// A single request this large is about to fail (and abort the process):
/// the case is named on stderr first.
const HUGE_REQUEST: usize = 1 << 30;
/// Slowest case accepted (debug build, two busy cores).
const SLOW_CASE: Duration = Duration::from_secs(10);

fn grew(size: usize) {
    let _ = LIVE.try_with(|live| {
        let v = live.get() + size as i64;
        live.set(v);
        let _ = PEAK.try_with(|p| p.set(p.get().max(v)));
    });
    if size >= HUGE_REQUEST {
        if let Ok(Some((label, case))) = CASE.try_with(|c| c.take()) {
            // No allocation here: format into a stack buffer.
            let mut buf = [0u8; 512];
            let mut w = Cursor::new(&mut buf[..]);
            let _ = writeln!(
                w,
                "fuzz: seed {label} case {case} asks for {size} bytes in one allocation"
            );
            let n = w.position() as usize;
            let _ = std::io::stderr().write_all(&buf[..n]);
        }
    }
}

fn shrank(size: usize) {
    let _ = LIVE.try_with(|live| live.set(live.get() - size as i64));
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        shrank(layout.size());
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        shrank(layout.size());
        grew(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Runs `f` and returns its value with the most bytes it held at once on
/// this thread beyond what was live before.
pub(crate) fn with_peak<T>(label: &'static str, case: u64, f: impl FnOnce() -> T) -> (T, i64) {
    let before = LIVE.with(|l| l.get());
    PEAK.with(|p| p.set(before));
    CASE.with(|c| c.set(Some((label, case))));
    let value = f();
    CASE.with(|c| c.set(None));
    let peak = PEAK.with(|p| p.get()) - before;
    (value, peak)
}

// ---------------------------------------------------------------------------
// Mutations.

/// Replacements for a run of digits: counts, sizes and times far outside
/// anything real, signs and the non-numbers.
const EXTREMES: [&str; 16] = [
    "0",
    "-1",
    "1000000000000",
    "999999999999999999999",
    "4294967296",
    "2147483648",
    "-2147483649",
    "18446744073709551616",
    "1e300",
    "-1e300",
    "1e-300",
    "9e99999",
    "nan",
    "inf",
    "99999",
    "65535",
];

/// Bytes of a binary header field set to an extreme integer.
const EXTREME_BYTES: [&[u8]; 6] = [
    &[0x00; 8],
    &[0xff; 8],
    &[0x7f, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff],
    &[0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x7f],
    &[0x80, 0, 0, 0, 0, 0, 0, 0],
    &[0x7f, 0x7f, 0x7f, 0x7f, 0x7f, 0x7f, 0x7f, 0x7f],
];

/// Headers sit at the start of every format: most positions fall there.
const HEAD_ZONE: usize = 4096;

struct Mutator {
    rng: SplitMix64,
}

impl Mutator {
    fn new(seed_no: u64, case: u64) -> Mutator {
        Mutator {
            rng: SplitMix64::new(0x9e37_79b9_7f4a_7c15 ^ (seed_no << 40) ^ case),
        }
    }
    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.rng.next_u64() % n as u64) as usize
        }
    }
    /// A position in `0..len`, three times in four inside the head zone.
    fn position(&mut self, len: usize) -> usize {
        if self.below(4) < 3 {
            self.below(len.min(HEAD_ZONE))
        } else {
            self.below(len)
        }
    }

    /// One to three mutations of `seed`; the description says which.
    fn mutate(&mut self, seed: &[u8]) -> (Vec<u8>, String) {
        let mut b = seed.to_vec();
        let mut said = Vec::new();
        for _ in 0..1 + self.below(3) {
            said.push(self.one(&mut b));
        }
        (b, said.join(", "))
    }

    fn one(&mut self, b: &mut Vec<u8>) -> String {
        if b.is_empty() {
            b.extend_from_slice(b"0\n");
            return "empty → \"0\\n\"".into();
        }
        match self.below(8) {
            0 => {
                let at = self.position(b.len());
                b.truncate(at);
                format!("truncated at {at}")
            }
            1 => {
                let flips = 1 + self.below(8);
                for _ in 0..flips {
                    let i = self.position(b.len());
                    b[i] ^= 1 << self.below(8);
                }
                format!("{flips} bit flips")
            }
            2 => {
                let at = self.position(b.len());
                let n = 1 + self.below(16);
                let bytes: Vec<u8> = (0..n).map(|_| self.rng.next_u64() as u8).collect();
                b.splice(at..at, bytes);
                format!("{n} bytes inserted at {at}")
            }
            3 => {
                let at = self.position(b.len());
                let n = (1 + self.below(64)).min(b.len() - at);
                b.drain(at..at + n);
                format!("{n} bytes deleted at {at}")
            }
            4 => self.extreme_number(b),
            5 => {
                let at = self.position(b.len());
                let n = 10 + self.below(40);
                let digit = b'0' + self.below(10) as u8;
                b.splice(at..at, std::iter::repeat_n(digit, n));
                format!("run of {n} '{}' at {at}", digit as char)
            }
            6 => {
                let at = self.position(b.len());
                let pattern = EXTREME_BYTES[self.below(EXTREME_BYTES.len())];
                let width = [2, 4, 8][self.below(3)];
                let end = (at + width).min(b.len());
                b[at..end].copy_from_slice(&pattern[..end - at]);
                format!("{width}-byte field at {at} = {:02x?}", &pattern[..end - at])
            }
            _ => {
                let at = self.position(b.len());
                let n = (1 + self.below(256)).min(b.len() - at);
                let times = 1 + self.below(8);
                let chunk = b[at..at + n].to_vec();
                for _ in 0..times {
                    b.splice(at..at, chunk.iter().copied());
                }
                format!("{n} bytes at {at} repeated {times} times")
            }
        }
    }

    /// Replaces a run of digits (one of the first in the head zone, mostly)
    /// by an extreme value.
    fn extreme_number(&mut self, b: &mut Vec<u8>) -> String {
        let zone = if self.below(4) < 3 {
            b.len().min(HEAD_ZONE)
        } else {
            b.len()
        };
        let mut runs = Vec::new();
        let mut i = 0;
        while i < zone {
            if b[i].is_ascii_digit() {
                let start = i;
                while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
                    i += 1;
                }
                runs.push(start..i);
            } else {
                i += 1;
            }
        }
        let value = EXTREMES[self.below(EXTREMES.len())];
        if runs.is_empty() {
            let at = self.position(b.len());
            b.splice(at..at, value.bytes());
            return format!("{value} inserted at {at}");
        }
        let run = runs[self.below(runs.len())].clone();
        let at = run.start;
        b.splice(run, value.bytes());
        format!("number at {at} = {value}")
    }
}

// ---------------------------------------------------------------------------
// Targets: what a seed is fed to.

#[derive(Clone)]
enum Target {
    /// One reader (and content sniffing) on the bytes.
    Reader(Format, ReadOptions),
    /// StationXML metadata.
    StationXml,
    /// The event folder loader on a folder whose file `name` is replaced
    /// (the manifest, or a record beside it), or on a zipped event.
    EventFolder(PathBuf),
    /// A twin file parsed and assembled.
    Twin,
    /// A design file loaded against its twin (folder with the twin beside it).
    Design(PathBuf),
}

struct Seed {
    /// File name used in errors (the message must name it).
    name: String,
    label: &'static str,
    bytes: Vec<u8>,
    target: Target,
}

#[derive(Debug)]
struct Failure {
    seed: String,
    case: u64,
    mutation: String,
    what: String,
    input: Vec<u8>,
}

#[derive(Default)]
struct Tally {
    cases: u64,
    ok: u64,
    errors: u64,
    max_peak: i64,
    slowest: Duration,
    slowest_case: String,
    failures: Vec<Failure>,
}

impl Tally {
    fn merge(&mut self, o: Tally) {
        self.cases += o.cases;
        self.ok += o.ok;
        self.errors += o.errors;
        self.max_peak = self.max_peak.max(o.max_peak);
        if o.slowest > self.slowest {
            self.slowest = o.slowest;
            self.slowest_case = o.slowest_case;
        }
        self.failures.extend(o.failures);
    }
}

fn source(name: &str) -> SourceRef {
    SourceRef {
        file: name.to_string(),
        ..Default::default()
    }
}

/// Feeds `bytes` to the target; `Ok(())` or the error text and exit code.
fn feed(seed: &Seed, bytes: &[u8], scratch: &Path) -> Result<(), (String, i32)> {
    let err = |e: quaketwin::Error| (e.to_string(), e.exit_code());
    match &seed.target {
        Target::Reader(format, opts) => {
            let _ = readers::classify(&seed.name, bytes);
            readers::read(*format, bytes, &source(&seed.name), opts)
                .map(|_| ())
                .map_err(err)
        }
        Target::StationXml => stationxml::parse(bytes, &source(&seed.name))
            .map(|_| ())
            .map_err(err),
        Target::EventFolder(folder) => {
            let event = if folder.extension().is_some_and(|e| e == "zip") {
                let zip = scratch.join(&seed.name);
                std::fs::write(&zip, bytes).unwrap();
                zip
            } else {
                let dir = scratch.join("event");
                if !dir.exists() {
                    copy_dir(folder, &dir);
                }
                std::fs::write(dir.join(&seed.name), bytes).unwrap();
                dir
            };
            event_folder::load(&event).map(|_| ()).map_err(err)
        }
        Target::Twin => {
            let text = String::from_utf8_lossy(bytes);
            quaketwin::twin::file::parse_twin(&text, &seed.name, scratch)
                .map(|_| ())
                .map_err(err)
        }
        Target::Design(folder) => {
            let dir = scratch.join("design");
            if !dir.exists() {
                copy_dir(folder, &dir);
            }
            let path = dir.join(&seed.name);
            std::fs::write(&path, bytes).unwrap();
            let design = load_design(&path).map_err(err)?;
            // The base motion from the facade's (unconditioned) base channel:
            // scale, duration, channel and axis choices of the file applied.
            if let MotionSource::Event { channels, axes, .. } = &design.motion.source {
                let model = design.model().map_err(err)?;
                base_motion_from_event(
                    facade_event(),
                    "facade",
                    channels,
                    axes,
                    &design.motion,
                    model,
                    &design.source,
                )
                .map_err(err)?;
            }
            Ok(())
        }
    }
}

/// Files an error about this seed may name instead of the seed itself (the
/// twin a design names, the records a manifest lists).
fn neighbours(seed: &Seed) -> Vec<String> {
    let folder = match &seed.target {
        Target::EventFolder(f) | Target::Design(f) if f.is_dir() => f,
        _ => return vec![],
    };
    std::fs::read_dir(folder)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

/// The sample facade event as read (loaded once).
fn facade_event() -> &'static Event {
    static EVENT: std::sync::OnceLock<Event> = std::sync::OnceLock::new();
    EVENT.get_or_init(|| {
        event_folder::load(&root().join("sample-records/synthetic-facade"))
            .unwrap()
            .event
    })
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

/// Runs cases `cases` of seed number `seed_no`.
fn fuzz_seed(seed_no: u64, seed: &Seed, cases: std::ops::Range<u64>, save: Option<&Path>) -> Tally {
    let scratch = tempfile::tempdir().unwrap();
    let names = neighbours(seed);
    let mut tally = Tally::default();
    for case in cases {
        let (input, mutation) = Mutator::new(seed_no, case).mutate(&seed.bytes);
        let t0 = Instant::now();
        let (outcome, peak) = with_peak(seed.label, case, || {
            catch_unwind(AssertUnwindSafe(|| feed(seed, &input, scratch.path())))
        });
        let took = t0.elapsed();
        tally.cases += 1;
        tally.max_peak = tally.max_peak.max(peak);
        if took > tally.slowest {
            tally.slowest = took;
            tally.slowest_case = format!("{} case {case} ({mutation})", seed.name);
        }
        let mut problems = Vec::new();
        match &outcome {
            Err(panic) => problems.push(format!(
                "panicked: {}",
                panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default()
            )),
            Ok(Ok(())) => tally.ok += 1,
            Ok(Err((message, code))) => {
                tally.errors += 1;
                if *code != 1 {
                    problems.push(format!("exit code {code} for bad data: {message}"));
                }
                let named = message.contains(&seed.name)
                    || names.iter().any(|n| message.contains(n.as_str()));
                if !named {
                    problems.push(format!("error does not name the file: {message}"));
                }
            }
        }
        if peak > PEAK_BOUND {
            problems.push(format!("held {peak} bytes at once"));
        }
        if took > SLOW_CASE {
            problems.push(format!("took {took:?}"));
        }
        for what in problems {
            if let Some(dir) = save {
                let _ = std::fs::create_dir_all(dir);
                let _ = std::fs::write(dir.join(format!("{}.case{case}", seed.name)), &input);
            }
            tally.failures.push(Failure {
                seed: seed.name.clone(),
                case,
                mutation: mutation.clone(),
                what,
                input: if input.len() <= 256 {
                    input.clone()
                } else {
                    vec![]
                },
            });
        }
    }
    tally
}

/// Runs `cases` cases of every seed (on every core) and fails listing every
/// failing case.
fn fuzz(seeds: &[Seed], cases: impl Fn(&Seed) -> u64, save: Option<&Path>) -> Tally {
    use rayon::prelude::*;
    // Chunks of 250 cases, so that a few big seeds do not serialise the run.
    let jobs: Vec<(usize, std::ops::Range<u64>)> = seeds
        .iter()
        .enumerate()
        .flat_map(|(i, s)| {
            let n = cases(s);
            (0..n.div_ceil(250)).map(move |k| (i, k * 250..((k + 1) * 250).min(n)))
        })
        .collect();
    let tallies: Vec<Tally> = jobs
        .into_par_iter()
        .map(|(i, range)| fuzz_seed(i as u64, &seeds[i], range, save))
        .collect();
    let mut total = Tally::default();
    for t in tallies {
        total.merge(t);
    }
    total
}

fn assert_clean(what: &str, t: &Tally, started: Instant) {
    eprintln!(
        "fuzz {what}: {} cases ({} ok, {} errors) in {:.2?}; largest peak {} kB; slowest {:.2?} ({})",
        t.cases,
        t.ok,
        t.errors,
        started.elapsed(),
        t.max_peak >> 10,
        t.slowest,
        t.slowest_case
    );
    if !t.failures.is_empty() {
        let list: Vec<String> = t
            .failures
            .iter()
            .take(40)
            .map(|f| {
                format!(
                    "  {} case {} [{}]: {}{}",
                    f.seed,
                    f.case,
                    f.mutation,
                    f.what,
                    if f.input.is_empty() {
                        String::new()
                    } else {
                        format!("\n    input: {:?}", String::from_utf8_lossy(&f.input))
                    }
                )
            })
            .collect();
        panic!(
            "{} failing fuzz case(s) of {}:\n{}",
            t.failures.len(),
            t.cases,
            list.join("\n")
        );
    }
}

// ---------------------------------------------------------------------------
// Seeds.

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn sample(rel: &str) -> Vec<u8> {
    let p = root().join("sample-records").join(rel);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The first `n` samples of a PEER AT2 file (header count rewritten).
fn short_at2(text: &str, n: usize) -> String {
    let mut out = String::new();
    let mut values = 0;
    for (i, line) in text.lines().enumerate() {
        if i < 3 {
            out += line;
        } else if i == 3 {
            let dt = line.split("DT=").nth(1).unwrap_or(" 0.01 SEC");
            out += &format!("NPTS= {n:7}, DT={dt}");
        } else if values < n {
            let keep: Vec<&str> = line.split_whitespace().take(n - values).collect();
            values += keep.len();
            out += &keep.join("  ");
        } else {
            break;
        }
        out.push('\n');
    }
    out
}

/// `line` with every whitespace-separated field equal to one of `counts`
/// replaced by `n`, right-aligned in the field's width (fixed-width formats).
fn recount(line: &str, counts: &[usize], n: usize) -> String {
    let mut out = String::new();
    let mut rest = line;
    while let Some(start) = rest.find(|c: char| !c.is_whitespace()) {
        let end = rest[start..]
            .find(char::is_whitespace)
            .map_or(rest.len(), |e| start + e);
        let field = &rest[start..end];
        out += &rest[..start];
        match field.parse::<usize>() {
            Ok(v) if counts.contains(&v) => out += &format!("{n:>w$}", w = field.len()),
            _ => out += field,
        }
        rest = &rest[end..];
    }
    out + rest
}

/// The first `n` samples of every data block of a text record whose blocks
/// follow a head line (`is_head`) starting with their count, `per_line`
/// values a line (COSMOS, CSMIP V2); the counts in the header rewritten.
fn short_blocks(text: &str, n: usize, per_line: usize, is_head: impl Fn(&str) -> bool) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let count = |l: &str| {
        l.split_whitespace()
            .next()
            .unwrap()
            .parse::<usize>()
            .unwrap()
    };
    let counts: Vec<usize> = lines
        .iter()
        .filter(|l| is_head(l))
        .map(|l| count(l))
        .collect();
    let mut out = String::new();
    let mut i = 0;
    while i < lines.len() {
        out += &recount(lines[i], &counts, n);
        out.push('\n');
        if is_head(lines[i]) {
            for l in &lines[i + 1..i + 1 + n.div_ceil(per_line)] {
                out += l;
                out.push('\n');
            }
            i += count(lines[i]).div_ceil(per_line);
        }
        i += 1;
    }
    out
}

/// The first `n` samples of every block of every component of a GeoNet
/// V2A file (16 text lines, 10 header lines, then acceleration, velocity
/// and displacement, 10 values a line); the counts in the headers rewritten.
fn short_geonet(text: &str, n: usize) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = String::new();
    let mut i = 0;
    while i + 26 <= lines.len() {
        let npts: usize = lines[i + 9]
            .split_whitespace()
            .nth(3)
            .unwrap()
            .parse()
            .unwrap();
        let block = npts.div_ceil(10);
        let kept = (0..3).flat_map(|b| &lines[i + 26 + b * block..][..n / 10]);
        for l in lines[i..i + 26]
            .iter()
            .map(|l| recount(l, &[npts], n))
            .chain(kept.map(|l| l.to_string()))
        {
            out += &l;
            out.push('\n');
        }
        i += 26 + 3 * block;
    }
    out
}

/// Seeds cut to 400 samples a channel, for the cargo-fuzz targets: a case of
/// the 300–430 kB COSMOS, CSMIP and GeoNet files takes 0.1–0.6 s under the
/// fuzzer's instrumentation.  Each must still read, 400 samples a channel.
fn short_seeds(seeds: &[Seed]) -> Vec<Seed> {
    type Cut = fn(&str) -> String;
    let cuts: [(&str, &'static str, Format, Cut); 3] = [
        ("cosmos-v0", "cosmos-v0-400", Format::Cosmos, |t| {
            short_blocks(t, 400, 1, |l| l.contains(" pts,"))
        }),
        ("csmip-v2", "csmip-v2-400", Format::Dmg, |t| {
            short_blocks(t, 400, 8, |l| l.contains(" DATA EQUALLY SPACED"))
        }),
        ("geonet", "geonet-400", Format::GeoNet, |t| {
            short_geonet(t, 400)
        }),
    ];
    cuts.iter()
        .map(|&(from, label, format, cut)| {
            let seed = seeds.iter().find(|s| s.label == from).unwrap();
            let short = cut(&String::from_utf8_lossy(&seed.bytes));
            let read = readers::read(
                format,
                short.as_bytes(),
                &source(&seed.name),
                &ReadOptions::default(),
            )
            .unwrap_or_else(|e| panic!("{label}: {e}"));
            assert!(
                read.records.iter().all(|r| r.samples.len() == 400),
                "{label}"
            );
            reader_seed(&seed.name, label, short.into_bytes(), format)
        })
        .collect()
}

/// The first `rows` rows of a CSV (header kept).
fn head_lines(text: &str, rows: usize) -> String {
    text.lines()
        .take(rows + 1)
        .map(|l| format!("{l}\n"))
        .collect()
}

/// A small copy of the sample quake (records cut to 400 samples) in `dir`,
/// for the event-folder targets.
fn small_quake(dir: &Path) -> PathBuf {
    let ev = dir.join("small-quake");
    std::fs::create_dir_all(&ev).unwrap();
    let s = "synthetic-4storey-quake";
    for f in ["base_X.AT2", "base_Y.AT2"] {
        let text = String::from_utf8(sample(&format!("{s}/{f}"))).unwrap();
        std::fs::write(ev.join(f), short_at2(&text, 400)).unwrap();
    }
    let floors = String::from_utf8(sample(&format!("{s}/floors.csv"))).unwrap();
    std::fs::write(ev.join("floors.csv"), head_lines(&floors, 400)).unwrap();
    for f in ["event.toml", "twin.toml"] {
        std::fs::write(ev.join(f), sample(&format!("{s}/{f}"))).unwrap();
    }
    ev
}

/// The small quake zipped (the zip member names are the file names).
fn zipped(folder: &Path) -> Vec<u8> {
    let mut w = zip::ZipWriter::new(Cursor::new(Vec::new()));
    let mut names: Vec<_> = std::fs::read_dir(folder)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    for p in names {
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        w.start_file(name, zip::write::SimpleFileOptions::default())
            .unwrap();
        w.write_all(&std::fs::read(&p).unwrap()).unwrap();
    }
    w.finish().unwrap().into_inner()
}

/// An MCAP file of the small quake's records, written by our own writer.
fn small_mcap(folder: &Path) -> Vec<u8> {
    let loaded = event_folder::load(folder).unwrap();
    let event: Event = loaded.event;
    mcap_writer::write_event_to(
        &event,
        Cursor::new(Vec::new()),
        &McapWriteOptions::default(),
        Path::new("small.mcap"),
    )
    .unwrap()
    .into_inner()
}

fn reader_seed(name: &str, label: &'static str, bytes: Vec<u8>, format: Format) -> Seed {
    Seed {
        name: name.into(),
        label,
        bytes,
        target: Target::Reader(format, ReadOptions::default()),
    }
}

/// Seeds from `sample-records/` only; `dir` holds the folders they need.
fn sample_seeds(dir: &Path) -> Vec<Seed> {
    let quake = small_quake(dir);
    let facade = root().join("sample-records/synthetic-facade");
    let floors = std::fs::read(quake.join("floors.csv")).unwrap();
    let mut seeds = vec![
        reader_seed(
            "base_X.AT2",
            "at2",
            std::fs::read(quake.join("base_X.AT2")).unwrap(),
            Format::At2,
        ),
        reader_seed("floors.csv", "csv", floors.clone(), Format::Csv),
        Seed {
            name: "floors.csv".into(),
            label: "csv-time-column",
            bytes: floors,
            target: Target::Reader(
                Format::Csv,
                ReadOptions {
                    time_column: Some("time_s".into()),
                    columns: Some(vec!["acc_L1_X".into(), "acc_L4_Y".into()]),
                    ..Default::default()
                },
            ),
        },
        reader_seed("small.mcap", "mcap", small_mcap(&quake), Format::Mcap),
        Seed {
            name: "event.toml".into(),
            label: "manifest",
            bytes: std::fs::read(quake.join("event.toml")).unwrap(),
            target: Target::EventFolder(quake.clone()),
        },
        Seed {
            name: "quake.zip".into(),
            label: "zip",
            bytes: zipped(&quake),
            target: Target::EventFolder(PathBuf::from("quake.zip")),
        },
        Seed {
            name: "twin.toml".into(),
            label: "twin",
            bytes: sample("synthetic-4storey-quake/twin.toml"),
            target: Target::Twin,
        },
        Seed {
            name: "facade.toml".into(),
            label: "twin-facade",
            bytes: sample("synthetic-facade/facade.toml"),
            target: Target::Twin,
        },
        Seed {
            name: "design.toml".into(),
            label: "design",
            bytes: sample("synthetic-facade/design.toml"),
            target: Target::Design(facade.clone()),
        },
        Seed {
            name: "event.toml".into(),
            label: "manifest-facade",
            bytes: sample("synthetic-facade/event.toml"),
            target: Target::EventFolder(facade),
        },
    ];
    seeds.sort_by_key(|s| s.label);
    seeds
}

fn shared(rel: &str) -> Vec<u8> {
    let p = super::common::shared_record(rel);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// A member of a zip in `../shared/records`.
fn shared_member(zip_rel: &str, member: &str) -> Vec<u8> {
    let bytes = shared(zip_rel);
    let mut z = zip::ZipArchive::new(Cursor::new(bytes)).unwrap();
    let mut f = z.by_name(member).unwrap();
    let mut out = Vec::new();
    std::io::Read::read_to_end(&mut f, &mut out).unwrap();
    out
}

/// Seeds from the real records of `../shared/records`, one or more per
/// format; large files are cut where the format allows it (MiniSEED records
/// of 512 bytes, SAC samples with the header count rewritten).
fn shared_seeds() -> Vec<Seed> {
    let g = "usgs-gmprocess-format-samples";
    let mseed = shared("nsmp-8040-anchorage-downhole-2018-mseed/NP.8040.D0.HNE.mseed");
    let mut sac = shared(&format!("{g}/sac/20190706031952.CJ.T001230.HNE.sac"));
    // SAC: keep 400 samples (NPTS is the 10th integer of the header, word 79).
    sac.truncate(632 + 4 * 400);
    sac[79 * 4..80 * 4].copy_from_slice(&400i32.to_le_bytes());
    let xsens = String::from_utf8_lossy(&shared(
        "mdof-mini-shake-table-flexible-3story/Ground Floor/(Northridge)Xsens DOT_20250306_122607.csv",
    ))
    .into_owned();
    let csv_lines: Vec<&str> = xsens.lines().collect();
    let xsens_head: String = csv_lines[..csv_lines.len().min(300)]
        .iter()
        .map(|l| format!("{l}\n"))
        .collect();
    vec![
        reader_seed(
            "TAK000.AT2",
            "at2-peer",
            shared("peer-at2-records/TAK000.AT2"),
            Format::At2,
        ),
        reader_seed(
            "0111b.smc",
            "smc",
            shared(&format!("{g}/smc/0111b.smc")),
            Format::Smc,
        ),
        reader_seed(
            "ce36456p_CE36456.V2",
            "csmip-v2",
            shared(&format!("{g}/dmg/ce36456p_CE36456.V2")),
            Format::Dmg,
        ),
        reader_seed(
            "CHAN1.V2",
            "csmip-v2-1992",
            shared_member(
                "csmip-ce89324-painterst-overpass/petrolia_25apr1992_ce89324p.zip",
                "CHAN1.V2",
            ),
            Format::Dmg,
        ),
        reader_seed(
            "NP8040-n.1000hyfh.HNE.01.V0c",
            "cosmos-v0",
            shared(&format!("{g}/cosmos/NP8040-n.1000hyfh.HNE.01.V0c")),
            Format::Cosmos,
        ),
        reader_seed(
            "20180212_211557_WPWS_20.V2A",
            "geonet",
            shared(&format!("{g}/geonet/20180212_211557_WPWS_20.V2A")),
            Format::GeoNet,
        ),
        reader_seed("T001230.HNE.sac", "sac", sac, Format::Sac),
        reader_seed(
            "NP.8040.D0.HNE.mseed",
            "mseed",
            mseed[..mseed.len().min(8 * 512)].to_vec(),
            Format::MiniSeed,
        ),
        Seed {
            name: "NP.8040.xml".into(),
            label: "stationxml",
            bytes: shared("nsmp-8040-anchorage-downhole-2018-mseed/NP.8040.xml"),
            target: Target::StationXml,
        },
        reader_seed(
            "xsens.csv",
            "csv-xsens",
            xsens_head.into_bytes(),
            Format::Csv,
        ),
    ]
}

/// Cases per seed in `cargo test`: a few thousand per reader (the issue-14
/// budget), fewer for the seeds that cost more per case; about 6 s over all
/// fuzz tests on two cores in the test profile.
fn ci_cases(seed: &Seed) -> u64 {
    match seed.bytes.len() {
        0..=20_000 => 2_000,
        20_001..=100_000 => 800,
        _ => 250,
    }
}

/// Every reader whose seeds come from `sample-records/` (AT2, CSV, MCAP),
/// the event manifest (plain and zipped events), twin and design files.
#[test]
fn fuzz_sample_seeds_every_target() {
    let dir = tempfile::tempdir().unwrap();
    let seeds = sample_seeds(dir.path());
    let t0 = Instant::now();
    let tally = fuzz(&seeds, ci_cases, None);
    assert_clean("sample seeds", &tally, t0);
}

/// The readers of the real records' formats: COSMOS, CSMIP V2 (two eras),
/// SMC, GeoNet, SAC, MiniSEED, StationXML, PEER AT2, Xsens CSV.
#[test]
fn fuzz_shared_records_every_reader() {
    let seeds = shared_seeds();
    let t0 = Instant::now();
    let tally = fuzz(&seeds, ci_cases, None);
    assert_clean("shared records", &tally, t0);
}

/// The long run: `QUAKETWIN_FUZZ_CASES` cases in all (default 10⁶), spread
/// over every seed of both tests; `QUAKETWIN_FUZZ_SAVE=DIR` keeps the
/// failing inputs.  See docs/robustness.md.
#[test]
#[ignore]
fn fuzz_long_run() {
    let total: u64 = std::env::var("QUAKETWIN_FUZZ_CASES")
        .ok()
        .and_then(|s| s.replace('_', "").parse().ok())
        .unwrap_or(1_000_000);
    let save = std::env::var_os("QUAKETWIN_FUZZ_SAVE").map(PathBuf::from);
    let dir = tempfile::tempdir().unwrap();
    let mut seeds = sample_seeds(dir.path());
    seeds.extend(shared_seeds());
    let per_seed = total.div_ceil(seeds.len() as u64);
    let t0 = Instant::now();
    let tally = fuzz(&seeds, |_| per_seed, save.as_deref());
    assert_clean("long run", &tally, t0);
}

/// The cargo-fuzz target (`fuzz/fuzz_targets/`) a seed belongs to.
fn cargo_fuzz_target(seed: &Seed) -> &'static str {
    match &seed.target {
        Target::Reader(format, _) => format.name(),
        Target::StationXml => "stationxml",
        Target::EventFolder(p) if p.extension().is_some_and(|e| e == "zip") => "event_zip",
        Target::EventFolder(p) if p.ends_with("synthetic-facade") => "manifest_facade",
        Target::EventFolder(_) => "manifest",
        Target::Twin => "twin",
        Target::Design(_) => "design",
    }
}

/// Writes the seed corpus of the cargo-fuzz targets (`scripts/fuzz-corpus.sh`):
/// `$QUAKETWIN_FUZZ_CORPUS/seeds/<target>/<seed>` for every seed above (the
/// real records' too, read in place from `../shared/records`) and the
/// pipeline files, and the small quake folder the manifest target loads,
/// `$QUAKETWIN_FUZZ_CORPUS/events/small-quake/`.
#[test]
#[ignore]
fn fuzz_cargo_fuzz_corpus_shared() {
    let Some(out) = std::env::var_os("QUAKETWIN_FUZZ_CORPUS").map(PathBuf::from) else {
        panic!("set QUAKETWIN_FUZZ_CORPUS to the fuzz/ folder (scripts/fuzz-corpus.sh does)");
    };
    let events = out.join("events");
    let _ = std::fs::remove_dir_all(&events);
    let mut seeds = sample_seeds(&events);
    seeds.extend(shared_seeds());
    seeds.extend(short_seeds(&seeds));
    let corpus = out.join("seeds");
    let _ = std::fs::remove_dir_all(&corpus);
    let mut written = 0;
    for seed in &seeds {
        let dir = corpus.join(cargo_fuzz_target(seed));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join(format!("{}-{}", seed.label, seed.name)),
            &seed.bytes,
        )
        .unwrap();
        written += 1;
    }
    let dir = corpus.join("pipeline");
    std::fs::create_dir_all(&dir).unwrap();
    for e in std::fs::read_dir(root().join("pipelines")).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, dir.join(p.file_name().unwrap())).unwrap();
        written += 1;
    }
    eprintln!("{written} seeds in {}", corpus.display());
}

/// Replays the cases of the first long run (10⁶ cases) that failed, by seed
/// name and case number (seed numbers as in [`fuzz_long_run`]): an MCAP
/// Channel record whose string length claimed up to 4 GB (the mcap crate
/// reserves it before reading: 13 cases of up to 4.3 GB held), and a COSMOS
/// reference azimuth of 10²¹ summed with the channel's (integer overflow,
/// 6 cases).  All failed before their fix.
#[test]
fn fuzz_long_run_failures_replayed_shared() {
    const FAILED: [(&str, &[u64]); 2] = [
        (
            "small.mcap",
            &[
                2098, 3609, 5116, 7873, 8954, 12704, 15927, 18299, 28419, 36705, 45345, 48920,
                49620,
            ],
        ),
        (
            "NP8040-n.1000hyfh.HNE.01.V0c",
            &[343, 10353, 13425, 13701, 18504, 34064],
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    let mut seeds = sample_seeds(dir.path());
    seeds.extend(shared_seeds());
    let t0 = Instant::now();
    let mut tally = Tally::default();
    for (name, cases) in FAILED {
        let i = seeds.iter().position(|s| s.name == name).unwrap();
        for &case in cases {
            tally.merge(fuzz_seed(i as u64, &seeds[i], case..case + 1, None));
        }
    }
    assert_eq!(tally.cases, 19);
    assert_clean("long-run failures", &tally, t0);
}

// ---------------------------------------------------------------------------
// Reproducers of what mutation found (each failed before its fix).

/// A CSMIP header whose longitude ended in a multi-byte character
/// (`124.31ÿ`, from a flipped bit) was split inside that character: panic.
#[test]
fn fuzz_found_hemisphere_letter_split_inside_a_character() {
    use quaketwin::readers::textfmt::signed_degrees;
    assert_eq!(signed_degrees("124.31\u{ff}"), None);
    assert_eq!(signed_degrees("\u{ff}"), None);
    assert_eq!(signed_degrees("124.31W"), Some(-124.31));
    assert_eq!(signed_degrees(" 40.5N,"), Some(40.5));
}

/// A start time whose year a digit run made huge overflowed the nanosecond
/// arithmetic (a panic in debug builds, a wrapped time in release); found on
/// an Xsens CSV `StartTime:` line.  Times i64 nanoseconds cannot hold are no
/// time at all.
#[test]
fn fuzz_found_huge_years_are_no_time_not_an_overflow() {
    use quaketwin::readers::csv::parse_start_time;
    use quaketwin::vocab::{epoch_ns_from_civil, epoch_ns_from_ordinal, parse_iso8601_ns};
    assert_eq!(epoch_ns_from_civil(99_999_999_999, 3, 6, 12, 26, 7.0), None);
    assert_eq!(epoch_ns_from_civil(i64::MIN, 1, 1, 0, 0, 0.0), None);
    assert_eq!(epoch_ns_from_civil(2263, 1, 1, 0, 0, 0.0), None);
    assert_eq!(epoch_ns_from_civil(1677, 1, 1, 0, 0, 0.0), None);
    assert!(epoch_ns_from_civil(2262, 1, 1, 0, 0, 0.0).is_some());
    assert_eq!(epoch_ns_from_ordinal(2262, 200, 0, 0, 0.0), None);
    assert_eq!(parse_iso8601_ns("99999999999-01-01T00:00:00Z"), None);
    assert_eq!(parse_start_time("99999999999-03-06_12:26:07_000 PST"), None);
    assert_eq!(
        parse_start_time("2025-03-06_12:26:07_99999999999999 PST"),
        None
    );
    assert!(parse_start_time("2025-03-06_12:26:07_000 PST").is_some());
    let csv = "StartTime: ,99999999999-03-06_12:26:07_000 PST\n\ntime_s,acc_X\n0,0.1\n0.01,0.2\n0.02,0.3\n0.03,0.1\n";
    match readers::read(
        Format::Csv,
        csv.as_bytes(),
        &source("x.csv"),
        &ReadOptions::default(),
    ) {
        Ok(fc) => assert_eq!(fc.records[0].channel.start_ns, None),
        Err(e) => assert!(e.to_string().contains("x.csv"), "{e}"),
    }
}

/// A design whose `[motion] duration_s` is 1e308 overflowed the sample
/// count (panic in `quaketwin design`); it now takes the whole record.
#[test]
fn design_duration_longer_than_any_record_takes_the_whole_record() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("facade");
    copy_dir(&root().join("sample-records/synthetic-facade"), &dir);
    let text = std::fs::read_to_string(dir.join("design.toml")).unwrap();
    let text = text.replace("duration_s = 10.0", "duration_s = 1e308");
    assert!(text.contains("1e308"));
    std::fs::write(dir.join("design.toml"), text).unwrap();
    let design = load_design(&dir.join("design.toml")).unwrap();
    let MotionSource::Event { channels, axes, .. } = &design.motion.source else {
        panic!("the facade design's motion comes from its event");
    };
    let motion = base_motion_from_event(
        facade_event(),
        "facade",
        channels,
        axes,
        &design.motion,
        design.model().unwrap(),
        &design.source,
    )
    .unwrap();
    let base = facade_event()
        .records
        .iter()
        .find(|r| r.channel.id == "B-X")
        .unwrap();
    assert_eq!(motion.components[0].acceleration.len(), base.samples.len());
}
