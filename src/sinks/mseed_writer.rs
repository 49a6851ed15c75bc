//! MiniSEED 2 writer: the one encoder of data records (synthetic SDS
//! archives, `quaketwin synth-archive`; the big-input benchmark's files).
//!
//! Records of 4096 bytes, big-endian, one blockette 1000 (encoding, word
//! order, record length, bytes 48–55) and a blockette 100 (exact sampling
//! rate, bytes 56–67), data from byte 128 — the first 64-byte boundary after
//! the blockette chain (a data offset inside the chain, as 64 was, makes
//! ObsPy warn and other readers take blockette bytes for samples): INT32
//! (encoding 3, counts) or FLOAT32 (encoding 4), 992 samples per full record.  The start time of each record is the stream's start
//! plus the samples written before it divided by the rate, truncated to the
//! 100 µs of BTIME (exact for every rate whose sample interval is a multiple
//! of 100 µs: 1, 10, 20, 50, 100, 200 Hz…).  Read back by
//! [`crate::readers::mseed`].

use crate::error::Result;
pub use crate::readers::mseed::StreamCodes;
use crate::vocab::ordinal_from_epoch_ns;

/// Bytes of every record written.
pub const RECORD_LEN: usize = 4096;
/// End of the blockette chain: the fixed header (48 bytes), blockette 1000
/// (8) and blockette 100 (12).
const BLOCKETTES_END: usize = 68;
/// First byte of the data: the chain's end rounded up to 64 bytes.
pub const DATA_OFFSET: usize = BLOCKETTES_END.div_ceil(64) * 64;
/// Samples in a full record (4-byte samples).
pub const SAMPLES_PER_RECORD: usize = (RECORD_LEN - DATA_OFFSET) / 4;

/// Sample encoding of the records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleEncoding {
    /// SEED encoding 3: samples rounded to whole counts (saturating at the i32 range).
    Int32,
    /// SEED encoding 4.
    Float32,
}

/// Cuts one continuous stream into records; each finished record is handed
/// to the caller with its start time (an SDS writer picks the day file from it).
#[derive(Debug, Clone)]
pub struct RecordEncoder {
    codes: StreamCodes,
    rate_hz: f64,
    start_ns: i64,
    encoding: SampleEncoding,
    sequence: u32,
    /// Samples already in records (the next record's first sample index).
    written: u64,
    pending: Vec<f64>,
}

impl RecordEncoder {
    pub fn new(codes: StreamCodes, rate_hz: f64, start_ns: i64, encoding: SampleEncoding) -> Self {
        RecordEncoder {
            codes,
            rate_hz,
            start_ns,
            encoding,
            sequence: 0,
            written: 0,
            pending: Vec::new(),
        }
    }

    /// Appends samples; every full record is passed to `emit(start_ns, bytes)`.
    pub fn push(
        &mut self,
        samples: &[f64],
        emit: &mut impl FnMut(i64, &[u8]) -> Result<()>,
    ) -> Result<()> {
        self.pending.extend_from_slice(samples);
        while self.pending.len() >= SAMPLES_PER_RECORD {
            self.record(SAMPLES_PER_RECORD, emit)?;
        }
        Ok(())
    }

    /// Writes what is left as a last, shorter record.
    pub fn finish(&mut self, emit: &mut impl FnMut(i64, &[u8]) -> Result<()>) -> Result<()> {
        if !self.pending.is_empty() {
            self.record(self.pending.len(), emit)?;
        }
        Ok(())
    }

    /// Start time of the next record to be written, ns.
    pub fn next_start_ns(&self) -> i64 {
        self.start_ns + (self.written as f64 * 1e9 / self.rate_hz).round() as i64
    }

    fn record(
        &mut self,
        count: usize,
        emit: &mut impl FnMut(i64, &[u8]) -> Result<()>,
    ) -> Result<()> {
        let mut r = vec![0u8; RECORD_LEN];
        self.sequence = self.sequence % 999_999 + 1;
        r[0..6].copy_from_slice(format!("{:06}", self.sequence).as_bytes());
        r[6] = b'D';
        r[7] = b' ';
        let pad = |s: &str, n: usize| {
            let mut v = format!("{s:<n$}").into_bytes();
            v.truncate(n);
            v
        };
        r[8..13].copy_from_slice(&pad(&self.codes.station, 5));
        r[13..15].copy_from_slice(&pad(&self.codes.location, 2));
        r[15..18].copy_from_slice(&pad(&self.codes.channel, 3));
        r[18..20].copy_from_slice(&pad(&self.codes.network, 2));
        let start = self.next_start_ns();
        let t = ordinal_from_epoch_ns(start);
        r[20..22].copy_from_slice(&(t.year as u16).to_be_bytes());
        r[22..24].copy_from_slice(&(t.day_of_year as u16).to_be_bytes());
        r[24] = t.hour as u8;
        r[25] = t.minute as u8;
        r[26] = t.second as u8;
        r[28..30].copy_from_slice(&((t.nanosecond / 100_000) as u16).to_be_bytes());
        r[30..32].copy_from_slice(&(count as u16).to_be_bytes());
        // Rate factor/multiplier for integer rates; blockette 100 holds the exact rate.
        let factor = if self.rate_hz.fract() == 0.0 && self.rate_hz <= i16::MAX as f64 {
            self.rate_hz as i16
        } else {
            0
        };
        r[32..34].copy_from_slice(&factor.to_be_bytes());
        r[34..36].copy_from_slice(&1i16.to_be_bytes());
        r[36] = 0x02; // activity: time correction applied (none needed)
        r[39] = 2; // blockettes 1000 and 100
        r[44..46].copy_from_slice(&(DATA_OFFSET as u16).to_be_bytes());
        r[46..48].copy_from_slice(&48u16.to_be_bytes());
        // Blockette 1000 at 48, next at 56.
        r[48..50].copy_from_slice(&1000u16.to_be_bytes());
        r[50..52].copy_from_slice(&56u16.to_be_bytes());
        r[52] = match self.encoding {
            SampleEncoding::Int32 => 3,
            SampleEncoding::Float32 => 4,
        };
        r[53] = 1; // big-endian
        r[54] = RECORD_LEN.trailing_zeros() as u8;
        // Blockette 100 at 56: exact sampling rate (float32), last in the chain.
        // (bytes 64–67: flags and reserved, zero; the chain ends at BLOCKETTES_END).
        r[56..58].copy_from_slice(&100u16.to_be_bytes());
        r[60..64].copy_from_slice(&(self.rate_hz as f32).to_bits().to_be_bytes());
        for (k, v) in self.pending.drain(..count).enumerate() {
            let at = DATA_OFFSET + 4 * k;
            let word = match self.encoding {
                SampleEncoding::Int32 => {
                    (v.round().clamp(i32::MIN as f64, i32::MAX as f64) as i32).to_be_bytes()
                }
                SampleEncoding::Float32 => (v as f32).to_be_bytes(),
            };
            r[at..at + 4].copy_from_slice(&word);
        }
        self.written += count as u64;
        emit(start, &r)
    }
}
