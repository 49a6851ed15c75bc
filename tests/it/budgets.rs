//! Resource budgets for untrusted containers (issue 33 item 2;
//! docs/robustness.md, Limits): zip members inflated as a stream under an
//! absolute, a relative and a per-member ratio budget; members the loader
//! skips never inflated beyond their head; `event.toml`, pipeline, design
//! and twin files size-capped before parsing; channel and stage counts
//! bounded; no cost quadratic in channels or stages; physically impossible
//! manifest values refused and impossible accelerations flagged.
//!
//! Every input is built here, in a temporary directory, from the
//! description of the failure (the zip bombs by a hand-written deflate
//! stream: 1 GiB of one byte in 1 MB).  Runs of the binary give the exit
//! code, the message and the wall time; memory is measured in process with
//! the test binary's counting allocator (a child's `ru_maxrss` includes
//! the test process it was spawned from).

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use quaketwin::event_folder::manifest::{MAX_CHANNELS, MAX_MANIFEST_BYTES};
use quaketwin::pipeline::config::{MAX_PIPELINE_BYTES, MAX_STAGES};

/// A member below the one-member limit (768 MiB), so that the ratio, the
/// manifest's cap or the budget — not the member limit — refuses it.
const BELOW_MEMBER_LIMIT: u64 = 700 << 20;
const GIB: u64 = 1 << 30;
const MB: u64 = 1 << 20;

// ---------------------------------------------------------------------------
// Running the binary; measuring memory in process.

struct Measured {
    code: i32,
    stderr: String,
    elapsed: Duration,
}

/// Runs `quaketwin --quiet ARGS`, killing it after `limit` (a hang fails
/// the test rather than the suite), with its exit code, stderr and wall time.
fn run(args: &[&OsStr], limit: Duration) -> Measured {
    let mut all = vec![OsStr::new("--quiet")];
    all.extend_from_slice(args);
    let here = std::env::current_dir().unwrap();
    let o = crate::child::run_quaketwin(&all, &here, limit);
    assert!(
        !o.timed_out,
        "quaketwin {args:?} still running after {limit:?}"
    );
    Measured {
        code: o.code.unwrap_or(-1),
        stderr: o.stderr,
        elapsed: o.elapsed,
    }
}

fn inspect(event: &Path) -> Measured {
    run(
        &[OsStr::new("inspect"), event.as_os_str()],
        Duration::from_secs(120),
    )
}

/// The most bytes `f` holds at once on this thread (the counting allocator
/// of the test binary, `fuzz::with_peak`): reading a zip and parsing a
/// manifest happen on the caller's thread.
fn peak_of<T>(f: impl FnOnce() -> T) -> (T, u64) {
    let (value, peak) = crate::fuzz::with_peak("budgets", 0, f);
    (value, peak.max(0) as u64)
}

/// Exit 1 within `time` naming every one of `words`, and the same event
/// refused in process (`inspect`'s loader) holding at most `peak` bytes.
fn assert_refused(event: &Path, what: &str, words: &[&str], peak: u64, time: Duration) {
    let m = inspect(event);
    assert_eq!(m.code, 1, "{what}: exit {} ({})", m.code, m.stderr);
    for w in words {
        assert!(m.stderr.contains(w), "{what}: {w:?} not in: {}", m.stderr);
    }
    assert!(m.elapsed <= time, "{what}: took {:?}", m.elapsed);
    let (result, held) = peak_of(|| quaketwin::event_folder::load_listing(event));
    let e = result.expect_err(what);
    assert!(e.to_string().contains(words[0]), "{what}: {e}");
    assert!(
        held <= peak,
        "{what}: held {} MB, above {} MB",
        held >> 20,
        peak >> 20
    );
}

// ---------------------------------------------------------------------------
// Zips built by hand: a deflate stream of one byte repeated (1032:1), the
// zip container around members.

/// Bits written least significant first, as deflate wants.
struct Bits {
    out: Vec<u8>,
    acc: u64,
    n: u32,
}

impl Bits {
    fn new() -> Bits {
        Bits {
            out: Vec::new(),
            acc: 0,
            n: 0,
        }
    }
    /// `len` bits of `v`, least significant first (header fields, extra bits).
    fn put(&mut self, v: u64, len: u32) {
        self.acc |= v << self.n;
        self.n += len;
        while self.n >= 8 {
            self.out.push(self.acc as u8);
            self.acc >>= 8;
            self.n -= 8;
        }
    }
    /// A Huffman code of `len` bits, most significant first.
    fn code(&mut self, code: u64, len: u32) {
        for i in (0..len).rev() {
            self.put((code >> i) & 1, 1);
        }
    }
    fn finish(mut self) -> Vec<u8> {
        if self.n > 0 {
            self.out.push(self.acc as u8);
        }
        self.out
    }
}

/// A raw deflate stream of `byte` repeated `n` times: one dynamic block
/// whose length code 285 (258 bytes back at distance 1) is one bit and its
/// distance code one bit, so 2 bits per 258 bytes.
fn deflate_repeated(byte: u8, n: u64) -> Vec<u8> {
    let mut b = Bits::new();
    b.put(1, 1); // final block
    b.put(2, 2); // dynamic Huffman
    b.put(29, 5); // 286 literal/length codes
    b.put(1, 5); // 2 distance codes
    b.put(14, 4); // 18 code-length codes
                  // Code-length code: 0, 1, 18 → 2 bits; 2, 17 → 3 bits (complete).
    let cl_len = |sym: usize| match sym {
        0 | 1 | 18 => 2,
        2 | 17 => 3,
        _ => 0,
    };
    const ORDER: [usize; 19] = [
        16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15,
    ];
    for &s in &ORDER[..18] {
        b.put(cl_len(s), 3);
    }
    let cl_code = |sym: usize| -> (u64, u32) {
        match sym {
            0 => (0b00, 2),
            1 => (0b01, 2),
            18 => (0b10, 2),
            2 => (0b110, 3),
            17 => (0b111, 3),
            _ => unreachable!(),
        }
    };
    // Lengths: `byte` → 2, 256 → 2, 285 → 1; distances 0 and 1 → 1.
    let mut lengths = vec![0usize; 288];
    lengths[byte as usize] = 2;
    lengths[256] = 2;
    lengths[285] = 1;
    lengths[286] = 1;
    lengths[287] = 1;
    let mut i = 0;
    while i < lengths.len() {
        if lengths[i] != 0 {
            let (c, l) = cl_code(lengths[i]);
            b.code(c, l);
            i += 1;
            continue;
        }
        let run = lengths[i..].iter().take_while(|&&l| l == 0).count();
        if run >= 11 {
            let r = run.min(138);
            let (c, l) = cl_code(18);
            b.code(c, l);
            b.put((r - 11) as u64, 7);
            i += r;
        } else if run >= 3 {
            let (c, l) = cl_code(17);
            b.code(c, l);
            b.put((run - 3) as u64, 3);
            i += run;
        } else {
            let (c, l) = cl_code(0);
            b.code(c, l);
            i += 1;
        }
    }
    // Literal code of `byte` "10", end of block "11", length 258 "0",
    // distance 1 "0".
    b.code(0b10, 2);
    let rest = n - 1;
    for _ in 0..rest / 258 {
        b.code(0b00, 2);
    }
    for _ in 0..rest % 258 {
        b.code(0b10, 2);
    }
    b.code(0b11, 2);
    b.finish()
}

fn crc32(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &byte in data {
        crc ^= byte as u32;
        for _ in 0..8 {
            crc = (crc >> 1) ^ (0xEDB8_8320 & (crc & 1).wrapping_neg());
        }
    }
    !crc
}

/// A zip member: its name, method (0 stored, 8 deflated), bytes as stored,
/// size and CRC as claimed.
struct Member {
    name: String,
    method: u16,
    data: Vec<u8>,
    size: u32,
    crc: u32,
}

/// A stored member (its CRC right).
fn stored(name: &str, data: &[u8]) -> Member {
    Member {
        name: name.into(),
        method: 0,
        data: data.to_vec(),
        size: data.len() as u32,
        crc: crc32(data),
    }
}

/// `n` bytes of `byte`, deflated (its CRC is not computed: the loader must
/// refuse or skip it before reading it all).
fn bomb(name: &str, byte: u8, n: u64) -> Member {
    Member {
        name: name.into(),
        method: 8,
        data: deflate_repeated(byte, n),
        size: n as u32,
        crc: 0,
    }
}

fn zip(members: &[Member]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut central = Vec::new();
    let le16 = |v: &mut Vec<u8>, x: u16| v.extend_from_slice(&x.to_le_bytes());
    let le32 = |v: &mut Vec<u8>, x: u32| v.extend_from_slice(&x.to_le_bytes());
    for m in members {
        let offset = out.len() as u32;
        le32(&mut out, 0x0403_4b50);
        for x in [20, 0, m.method, 0, 0x21] {
            le16(&mut out, x);
        }
        for x in [m.crc, m.data.len() as u32, m.size] {
            le32(&mut out, x);
        }
        le16(&mut out, m.name.len() as u16);
        le16(&mut out, 0);
        out.extend_from_slice(m.name.as_bytes());
        out.extend_from_slice(&m.data);

        le32(&mut central, 0x0201_4b50);
        for x in [20, 20, 0, m.method, 0, 0x21] {
            le16(&mut central, x);
        }
        for x in [m.crc, m.data.len() as u32, m.size] {
            le32(&mut central, x);
        }
        for x in [m.name.len() as u16, 0, 0, 0, 0] {
            le16(&mut central, x);
        }
        le32(&mut central, 0);
        le32(&mut central, offset);
        central.extend_from_slice(m.name.as_bytes());
    }
    let cd_offset = out.len() as u32;
    out.extend_from_slice(&central);
    le32(&mut out, 0x0605_4b50);
    for x in [0, 0, members.len() as u16, members.len() as u16] {
        le16(&mut out, x);
    }
    le32(&mut out, central.len() as u32);
    le32(&mut out, cd_offset);
    le16(&mut out, 0);
    out
}

/// A small valid record: 2 s of a 100 Hz CSV acceleration column.
fn record_csv() -> Vec<u8> {
    let mut s = String::from("time,acc\n");
    for i in 0..200 {
        s.push_str(&format!(
            "{:.2},{}\n",
            i as f64 * 0.01,
            (i % 7) as f64 * 0.01
        ));
    }
    s.into_bytes()
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn hand_made_deflate_stream_inflates_to_what_it_claims() {
    // The generator itself, checked through the loader on a small member.
    let dir = tempfile::tempdir().unwrap();
    let mut m = bomb("flat.csv", b'7', 100_000);
    let data = vec![b'7'; 100_000];
    m.crc = crc32(&data);
    let p = write(
        dir.path(),
        "ok.zip",
        &zip(&[m, stored("rec.csv", &record_csv())]),
    );
    let files = quaketwin::event_folder::collect(&p, &Default::default()).unwrap();
    let flat = files.iter().find(|f| f.base_name() == "flat.csv").unwrap();
    assert_eq!(&*flat.content().unwrap(), &data[..]);
}

#[test]
fn zips_of_1_gib_members_are_refused_within_memory() {
    // 1 MB zips holding 1 GiB of commas, zeros or spaces (4–7 GB and an
    // abort before), and a zip holding a zip of such a CSV: refused for
    // their size before a byte is inflated.  Below the member limit
    // (700 MiB), refused for their ratio as they inflate.
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("commas.zip", zip(&[bomb("rec.csv", b',', GIB)])),
        ("zeros.zip", zip(&[bomb("rec.csv", b'0', GIB)])),
        ("spaces.zip", zip(&[bomb("rec.csv", b' ', GIB)])),
        (
            "nested.zip",
            zip(&[stored("inner.zip", &zip(&[bomb("rec.csv", b',', GIB)]))]),
        ),
    ];
    for (name, bytes) in cases.iter().take(2) {
        let big = name.replace(".zip", "-1gib.zip");
        let p = write(dir.path(), &big, bytes);
        assert_refused(
            &p,
            &big,
            &[
                &big,
                "rec.csv",
                "above the limit of 805306368 bytes for one member",
            ],
            64 * MB,
            Duration::from_secs(20),
        );
    }
    let cases = cases.map(|(name, _)| {
        let fill = match name {
            "zeros.zip" => b'0',
            "spaces.zip" => b' ',
            _ => b',',
        };
        let member = bomb("rec.csv", fill, BELOW_MEMBER_LIMIT);
        let bytes = if name == "nested.zip" {
            zip(&[stored("inner.zip", &zip(&[member]))])
        } else {
            zip(&[member])
        };
        (name, bytes)
    });
    for (name, bytes) in cases {
        assert!(
            bytes.len() as u64 <= 11 * MB / 10,
            "{name}: {} bytes",
            bytes.len()
        );
        let p = write(dir.path(), name, &bytes);
        assert_refused(
            &p,
            name,
            &[
                name,
                "rec.csv",
                "more than the limit of 100:1 for one member",
            ],
            128 * MB,
            Duration::from_secs(20),
        );
    }
}

#[test]
fn a_member_lying_about_its_size_is_stopped_at_its_claim() {
    // 1 GiB of zeros claiming 1 MB: inflated up to the claim, then refused.
    let dir = tempfile::tempdir().unwrap();
    let mut m = bomb("rec.csv", b'0', GIB);
    m.size = 1 << 20;
    let p = write(dir.path(), "liar.zip", &zip(&[m]));
    assert_refused(
        &p,
        "liar",
        &[
            "liar.zip",
            "rec.csv",
            "larger than its declared uncompressed size",
        ],
        128 * MB,
        Duration::from_secs(20),
    );
}

#[test]
fn the_event_budget_counts_every_member_and_level() {
    // 60 members of 1 MiB of zeros each (within the per-member grace) in a
    // zip of ~60 kB: 60 MiB decompressed is above 100 × the zip (and its
    // 16 MiB floor).
    let dir = tempfile::tempdir().unwrap();
    let mut members: Vec<Member> = (0..60)
        .map(|i| {
            let mut m = bomb(&format!("pad{i:02}.csv"), b'0', MB);
            m.crc = crc32(&vec![b'0'; MB as usize]);
            m
        })
        .collect();
    members.push(stored("rec.csv", &record_csv()));
    let bytes = zip(&members);
    let p = write(dir.path(), "many.zip", &bytes);
    assert_refused(
        &p,
        "many small members",
        &[
            "many.zip",
            "pad",
            &format!("above the limit of 100 × the {} bytes", bytes.len()),
        ],
        128 * MB,
        Duration::from_secs(20),
    );
}

#[test]
fn the_absolute_budget_is_checked_before_a_member_is_inflated() {
    // 12 members of 1 MiB against an absolute budget of 10 MiB (the
    // default, 2 GiB, needs a 20 MB zip: the mechanism is the same).
    let dir = tempfile::tempdir().unwrap();
    let members: Vec<Member> = (0..12)
        .map(|i| {
            let mut m = bomb(&format!("pad{i:02}.csv"), b'0', MB);
            m.crc = crc32(&vec![b'0'; MB as usize]);
            m
        })
        .collect();
    let p = write(dir.path(), "absolute.zip", &zip(&members));
    let limits = quaketwin::event_folder::ArchiveLimits {
        max_total_bytes: 10 * MB,
        ..Default::default()
    };
    let (result, held) = peak_of(|| quaketwin::event_folder::collect(&p, &limits));
    let msg = result.unwrap_err().to_string();
    assert!(
        msg.contains("absolute.zip:pad10.csv")
            && msg.contains("above the limit of 10485760 bytes decompressed per event"),
        "{msg}"
    );
    assert!(held <= 16 * MB, "held {} MB", held >> 20);
}

#[test]
fn skipped_members_are_never_inflated() {
    // Three 2 GiB members that are not records (6.2 GB before) beside one
    // record: listed as skipped, read only up to their heads.
    let dir = tempfile::tempdir().unwrap();
    let bytes = zip(&[
        bomb("dump.bin", 0, 2 * GIB),
        bomb("notes.txt", b' ', 2 * GIB),
        bomb("video.mp4", 0, 2 * GIB),
        stored("rec.csv", &record_csv()),
    ]);
    let p = write(dir.path(), "skips.zip", &bytes);
    let m = inspect(&p);
    assert_eq!(m.code, 0, "{}", m.stderr);
    assert!(m.elapsed <= Duration::from_secs(20), "{:?}", m.elapsed);
    let files = quaketwin::event_folder::collect(&p, &Default::default()).unwrap();
    for f in files.iter().filter(|f| f.base_name() != "rec.csv") {
        assert!(
            f.head.len() <= quaketwin::event_folder::HEAD_BYTES,
            "{}: {} bytes",
            f.base_name(),
            f.head.len()
        );
        assert_eq!(f.len(), 2 * GIB);
    }
    let (loaded, held) = peak_of(|| quaketwin::event_folder::load_listing(&p));
    let loaded = loaded.unwrap();
    assert!(held <= 64 * MB, "held {} MB", held >> 20);
    let skipped = loaded.files.iter().filter(|f| f.skipped.is_some()).count();
    assert_eq!(skipped, 3, "{:?}", loaded.files);
}

// ---------------------------------------------------------------------------
// The manifest.

/// The manifest entry of channel `k`: all on column `acc` of `rec.csv`.
fn channel_entry(k: usize) -> String {
    format!(
        "[[channel]]\nfile = \"rec.csv\"\ncolumn = \"acc\"\nid = \"C{k}\"\nunits = \"m/s2\"\nlevel = {}\ndirection = \"X\"\n",
        k % 5
    )
}

fn manifest_of(n: usize) -> String {
    (0..n).map(channel_entry).collect()
}

#[test]
fn a_manifest_of_a_million_channels_is_refused_by_its_size() {
    // A 40 MB manifest (2.5 GB before) as a file, and 10⁶ channels zipped
    // (> 8 GB before).
    let dir = tempfile::tempdir().unwrap();
    let text = manifest_of(450_000);
    assert!(text.len() as u64 >= 40 * MB);
    let ev = dir.path().join("big-manifest");
    std::fs::create_dir(&ev).unwrap();
    write(&ev, "rec.csv", &record_csv());
    write(&ev, "event.toml", text.as_bytes());
    drop(text);
    let limit = format!("larger than the limit of {MAX_MANIFEST_BYTES} bytes");
    assert_refused(
        &ev,
        "40 MB manifest",
        &["event.toml", &limit],
        96 * MB,
        Duration::from_secs(10),
    );
    // Zipped: 10⁶ entries claimed; the member's size is refused before it
    // is inflated (spaces of that length stand in for the deflated text,
    // which would take a while to make here).
    let claimed: u64 = (0..1_000_000).map(|k| channel_entry(k).len() as u64).sum();
    let member = bomb("event.toml", b' ', claimed);
    let p = write(
        dir.path(),
        "big-manifest.zip",
        &zip(&[member, stored("rec.csv", &record_csv())]),
    );
    assert_refused(
        &p,
        "zipped manifest",
        &[
            "big-manifest.zip",
            "event.toml",
            &format!("event manifest of {claimed} bytes"),
            &limit,
        ],
        96 * MB,
        Duration::from_secs(10),
    );
}

#[test]
fn an_event_toml_of_1_gib_of_nul_bytes_is_never_read() {
    // 3.1 GB before; as a (sparse) file and inside a zip.
    let dir = tempfile::tempdir().unwrap();
    let ev = dir.path().join("nul");
    std::fs::create_dir(&ev).unwrap();
    write(&ev, "rec.csv", &record_csv());
    std::fs::File::create(ev.join("event.toml"))
        .unwrap()
        .set_len(BELOW_MEMBER_LIMIT)
        .unwrap();
    let limit = format!("larger than the limit of {MAX_MANIFEST_BYTES} bytes");
    assert_refused(
        &ev,
        "NUL file",
        &["event.toml", &limit],
        64 * MB,
        Duration::from_secs(10),
    );
    let p = write(
        dir.path(),
        "nul.zip",
        &zip(&[
            bomb("event.toml", 0, BELOW_MEMBER_LIMIT),
            stored("rec.csv", &record_csv()),
        ]),
    );
    assert_refused(
        &p,
        "NUL member",
        &["nul.zip", "event.toml", &limit],
        64 * MB,
        Duration::from_secs(10),
    );
}

#[test]
fn manifest_channel_count_is_bounded() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "rec.csv", &record_csv());
    write(
        dir.path(),
        "event.toml",
        manifest_of(MAX_CHANNELS + 1).as_bytes(),
    );
    assert_refused(
        dir.path(),
        "channels",
        &[
            "event.toml",
            &format!(
                "{} channels: more than the limit of {MAX_CHANNELS}",
                MAX_CHANNELS + 1
            ),
        ],
        128 * MB,
        Duration::from_secs(10),
    );
}

#[test]
fn two_thousand_channels_on_one_column_take_linear_time() {
    // 215 s before (the rigid-floor check formed the mean of the others
    // once per channel); 2,000 and 4,000 channels now cost about the same
    // per channel.
    let time = |n: usize| {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "rec.csv", &record_csv());
        write(dir.path(), "event.toml", manifest_of(n).as_bytes());
        let m = inspect(dir.path());
        assert_eq!(m.code, 0, "{n} channels: {}", m.stderr);
        m.elapsed
    };
    let two = time(2000);
    let four = time(4000);
    assert!(two <= Duration::from_secs(5), "2000 channels: {two:?}");
    assert!(four <= Duration::from_secs(10), "4000 channels: {four:?}");
}

#[test]
fn rigid_floor_of_many_disagreeing_sensors_is_not_quadratic() {
    // 1,000 sensors on one level, every other one of another signal: the
    // check leaves out a few one at a time, then the rest together.
    use quaketwin::geometry::floor::{combine_floors, FloorSettings};
    use quaketwin::vocab::{Axis, Channel, Direction, Event, Record, SourceRef, Units};
    let mut event = Event::default();
    for k in 0..1000 {
        let mut c = Channel::new(format!("C{k}"), Units::MPerS2, 100.0, SourceRef::default());
        c.level = Some(1);
        c.direction = Some(Direction::Axis(Axis::X));
        let samples: Vec<f64> = (0..2000)
            .map(|t| {
                let t = t as f64 * 0.01;
                if k % 2 == 0 {
                    (6.0 * t).sin()
                } else {
                    (17.0 * t).cos()
                }
            })
            .collect();
        event.records.push(Record::new(c, samples));
    }
    let started = Instant::now();
    let done = combine_floors(&mut event, &FloorSettings::default()).unwrap();
    assert!(
        started.elapsed() <= Duration::from_secs(5),
        "{:?}",
        started.elapsed()
    );
    assert_eq!(done.len(), 1);
    assert!(!done[0].disagreeing.is_empty());
}

// ---------------------------------------------------------------------------
// Physical values.

#[test]
fn a_sensitivity_of_1e_minus_300_is_refused_where_it_is_parsed() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "rec.csv", &record_csv());
    write(
        dir.path(),
        "event.toml",
        b"[[channel]]\nfile = \"rec.csv\"\ncolumn = \"acc\"\nid = \"A1\"\nunits = \"counts\"\nsensitivity = 1e-300\n",
    );
    assert_refused(
        dir.path(),
        "sensitivity",
        &["event.toml", "A1", "sensitivity 1e-300"],
        64 * MB,
        Duration::from_secs(10),
    );
}

#[test]
fn physically_impossible_manifest_values_are_refused() {
    let cases: [(&str, &str); 7] = [
        ("sampling_rate_hz = 1e9", "sampling_rate_hz"),
        ("level = 100000", "level 100000"),
        ("elevation_m = 1e7", "elevation_m"),
        ("position_m = [1e300, 0.0]", "position_m"),
        ("sensitivity = 1e300\nunits = \"counts\"", "sensitivity"),
        ("sampling_rate_hz = 1e-9", "sampling_rate_hz"),
        ("sensitivity = nan\nunits = \"counts\"", "sensitivity"),
    ];
    for (line, word) in cases {
        let text = format!("[[channel]]\nfile = \"rec.csv\"\nid = \"A1\"\n{line}\n");
        let e = quaketwin::event_folder::Manifest::parse(&text, "event.toml").unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains(word) && msg.contains("A1"), "{line}: {msg}");
    }
    for (structure, word) in [
        ("storey_heights_m = [3.0, 1e6]", "storey_heights_m"),
        ("masses_kg = [1e300]", "masses_kg"),
        ("centre_of_mass_m = [1e9, 0.0]", "centre_of_mass_m"),
    ] {
        let text = format!("[structure]\n{structure}\n");
        let e = quaketwin::event_folder::Manifest::parse(&text, "event.toml").unwrap_err();
        assert!(e.to_string().contains(word), "{structure}: {e}");
    }
    let e = quaketwin::event_folder::Manifest::parse("[event]\nmagnitude = 42\n", "event.toml")
        .unwrap_err();
    assert!(e.to_string().contains("magnitude"), "{e}");
}

#[test]
fn an_acceleration_above_100_g_is_flagged() {
    // 200 g stated in g: the record is conditioned, and says it is impossible.
    let dir = tempfile::tempdir().unwrap();
    let mut s = String::from("time,acc [g]\n");
    for i in 0..400 {
        let v = if i == 250 {
            200.0
        } else {
            (i % 7) as f64 * 0.001
        };
        s.push_str(&format!("{:.2},{v}\n", i as f64 * 0.01));
    }
    write(dir.path(), "rec.csv", s.as_bytes());
    let mut event = quaketwin::event_folder::load(dir.path()).unwrap().event;
    quaketwin::conditioning::condition_event(&mut event, &Default::default()).unwrap();
    let flagged = event.records[0].channel.qa.iter().any(|f| {
        matches!(f, quaketwin::vocab::QaFlag::Note { text } if text.contains("physically impossible"))
    });
    assert!(flagged, "{:?}", event.records[0].channel.qa);
}

// ---------------------------------------------------------------------------
// Pipeline, design and twin files.

fn pipeline_of(n: usize) -> String {
    let mut s = String::from("[pipeline]\nname = \"many\"\n");
    for k in 0..n {
        s.push_str(&format!(
            "\n[[stage]]\nname = \"s{k}\"\nkind = \"ingest\"\n"
        ));
    }
    s
}

#[test]
fn a_pipeline_of_10000_stages_is_refused_at_once() {
    // 69 s before its exit 2 (every stage re-parsed the whole text).
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "many.toml", pipeline_of(10_000).as_bytes());
    write(dir.path(), "rec.csv", &record_csv());
    let out = dir.path().join("out");
    let m = run(
        &[
            OsStr::new("run"),
            p.as_os_str(),
            dir.path().as_os_str(),
            OsStr::new("--out"),
            out.as_os_str(),
        ],
        Duration::from_secs(60),
    );
    assert_eq!(m.code, 2, "{}", m.stderr);
    let want = format!("10000 stages declared: more than the limit of {MAX_STAGES}");
    assert!(
        m.stderr.contains(&want) && m.stderr.contains("many.toml"),
        "{}",
        m.stderr
    );
    assert!(m.elapsed <= Duration::from_secs(5), "{:?}", m.elapsed);
}

#[test]
fn a_pipeline_at_the_stage_limit_is_built_in_linear_time() {
    // Every stage is built (typed params) before the outputs are checked:
    // 256 ingest stages then collide on their output files.
    let text = pipeline_of(MAX_STAGES);
    let started = Instant::now();
    let e = quaketwin::stages::parse_pipeline(&text, "many.toml").unwrap_err();
    assert!(
        started.elapsed() <= Duration::from_secs(3),
        "{:?}",
        started.elapsed()
    );
    assert!(e.to_string().contains("would both write"), "{e}");
    assert_eq!(e.exit_code(), 2);
}

#[test]
fn oversized_pipeline_design_and_twin_files_are_refused_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    let sparse = |name: &str, len: u64| {
        let p = dir.path().join(name);
        std::fs::File::create(&p).unwrap().set_len(len).unwrap();
        p
    };
    let p = sparse("huge.toml", GIB);
    let e = quaketwin::stages::load_pipeline(&p).unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(
        e.to_string().contains(&format!(
            "larger than the limit of {MAX_PIPELINE_BYTES} bytes"
        )) && e.to_string().contains("huge.toml"),
        "{e}"
    );
    let p = sparse("design.toml", GIB);
    let e = quaketwin::design::file::load_design(&p).unwrap_err();
    assert!(
        e.to_string().contains("design file of 1073741824 bytes")
            && e.to_string().contains(&format!(
                "limit of {} bytes",
                quaketwin::design::file::MAX_DESIGN_FILE_BYTES
            )),
        "{e}"
    );
    let p = sparse("twin.toml", GIB);
    let e = quaketwin::twin::load_twin(&p).unwrap_err();
    assert!(
        e.to_string().contains("twin file of 1073741824 bytes")
            && e.to_string().contains(&format!(
                "limit of {} bytes",
                quaketwin::twin::file::MAX_TWIN_FILE_BYTES
            )),
        "{e}"
    );
}

#[test]
fn a_bomb_beside_a_referenced_file_is_not_extracted() {
    // A zipped event's referenced files are extracted member by member
    // within the budget: the bomb is left out, and is an error only if named.
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "twin-event.zip",
        &zip(&[
            bomb("junk.csv", b',', BELOW_MEMBER_LIMIT),
            stored("twin.toml", b"[twin]\nname = \"x\"\n"),
            stored("rec.csv", &record_csv()),
        ]),
    );
    let mut refs = quaketwin::event_folder::ReferencedFiles::new(&p);
    let (twin, held) = peak_of(|| refs.resolve("twin.toml", "structure.twin"));
    assert_eq!(
        std::fs::read(twin.unwrap()).unwrap(),
        b"[twin]\nname = \"x\"\n"
    );
    assert!(held <= 16 * MB, "held {} MB", held >> 20);
    let msg = refs
        .resolve("junk.csv", "design file")
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("junk.csv") && msg.contains("more than the limit of 100:1"),
        "{msg}"
    );
}

/// A text record larger than its format can hold (here a 300 MiB sparse
/// file named as a PEER AT2) is refused on its size, before a byte of it is
/// read: found by the structured fuzzing, where a 1 GiB "AT2" member within
/// the zip budgets was inflated whole before the reader refused it.
#[test]
fn text_record_above_its_format_limit_is_refused_unread() {
    let dir = tempfile::tempdir().unwrap();
    let ev = dir.path().join("event");
    std::fs::create_dir_all(&ev).unwrap();
    let f = std::fs::File::create(ev.join("big.AT2")).unwrap();
    f.set_len(300 << 20).unwrap();
    drop(f);
    let t0 = Instant::now();
    let (result, peak) =
        crate::fuzz::with_peak("budgets", 1, || quaketwin::event_folder::load(&ev));
    let e = result.expect_err("a 300 MiB AT2 is no record");
    let text = e.to_string();
    assert!(
        text.contains("big.AT2") && text.contains("268435456"),
        "{text}"
    );
    assert_eq!(e.exit_code(), 1);
    assert!(peak < 16 << 20, "held {peak} bytes");
    assert!(t0.elapsed() < Duration::from_secs(5), "{:?}", t0.elapsed());
}
