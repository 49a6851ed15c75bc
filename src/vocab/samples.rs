//! The samples of one channel: in memory, or **parked** in a sample store
//! (the run's spill file) while no stage needs them, so that an event of
//! many long channels is held in memory a channel at a time (issue 14 item 5).
//!
//! The vocabulary does no I/O: [`SampleStore`] is the interface, the
//! pipeline's spill file (`pipeline::spill`) the implementation.
//!
//! Reading parked samples:
//! - [`Samples::load`] reads them for the caller without keeping them (the
//!   channel-by-channel paths of the stages use it, so memory stays bounded);
//! - dereferencing (`&samples[..]`, `samples.iter()`) reads them once and
//!   keeps them cached in the value until it is dropped or [`Samples::release`]d
//!   (every other reader keeps working unchanged, at the memory cost of the
//!   channels it reads);
//! - mutable access (`samples.iter_mut()`) brings them back into memory for good.
//!
//! Parking and reading back are exact (the f64 bits are stored), so every
//! result is the same whether the samples were parked or not.  A sign flip of
//! parked samples ([`Samples::negate`]) is recorded, not applied, until they
//! are read (negation is exact too).

use std::borrow::Cow;
use std::sync::{Arc, OnceLock};

/// Where parked samples live.  Implementations must be safe to use from
/// several threads (channels are processed in parallel).
pub trait SampleStore: Send + Sync {
    /// Stores `values`; returns the position to read them back from.
    fn put(&self, values: &[f64]) -> std::io::Result<u64>;
    /// Reads `out.len()` values stored at `position` by [`SampleStore::put`],
    /// from the `offset`-th value on.
    fn get(&self, position: u64, offset: usize, out: &mut [f64]) -> std::io::Result<()>;
    /// What the store is, for error messages (e.g. the spill file's directory).
    fn describe(&self) -> String;
}

/// Samples parked in a store.
struct Parked {
    store: Arc<dyn SampleStore>,
    position: u64,
    /// The first stored value these samples start at (a window of a longer
    /// parked series, [`Samples::window`], shares its stored values).
    start: usize,
    len: usize,
    /// Read back negated (a sign flip recorded while parked).
    negate: bool,
    /// Read back multiplied by this after the sign flip (a view in other
    /// units, [`Samples::scaled`]); 1 for the values as stored.
    scale: f64,
    /// What dereferencing read, kept until released.
    cache: OnceLock<Vec<f64>>,
}

impl Parked {
    /// Values `start..start + len` of these (a window of them), multiplied
    /// by `factor`, reading the same stored values; nothing cached.
    fn view(&self, start: usize, len: usize, factor: f64) -> Parked {
        Parked {
            store: self.store.clone(),
            position: self.position,
            start: self.start + start,
            len,
            negate: self.negate,
            scale: self.scale * factor,
            cache: OnceLock::new(),
        }
    }
    fn read(&self) -> std::io::Result<Vec<f64>> {
        self.read_range(0, self.len)
    }
    fn read_range(&self, start: usize, len: usize) -> std::io::Result<Vec<f64>> {
        let mut v = vec![0.0; len];
        self.store.get(self.position, self.start + start, &mut v)?;
        if self.negate {
            v.iter_mut().for_each(|x| *x = -*x);
        }
        if self.scale != 1.0 {
            v.iter_mut().for_each(|x| *x *= self.scale);
        }
        Ok(v)
    }
    fn read_or_abort(&self) -> Vec<f64> {
        // The store is the run's own spill file, written moments ago: a read
        // failing here is a failing disk, not bad input, and dereferencing has
        // no error to return.  The channel-by-channel paths use `load`, which does.
        self.read().unwrap_or_else(|e| {
            panic!(
                "reading back parked samples from {}: {e}",
                self.store.describe()
            )
        })
    }
}

enum Repr {
    Memory(Vec<f64>),
    Parked(Parked),
}

/// One channel's samples (see the module doc).
pub struct Samples(Repr);

impl Samples {
    pub fn new(values: Vec<f64>) -> Self {
        Samples(Repr::Memory(values))
    }

    /// Number of samples (never reads parked samples).
    pub fn len(&self) -> usize {
        match &self.0 {
            Repr::Memory(v) => v.len(),
            Repr::Parked(p) => p.len,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether the samples are parked in a store (read back on use).
    pub fn is_parked(&self) -> bool {
        matches!(self.0, Repr::Parked(_))
    }

    /// Parks the samples in `store` and frees their memory.  Parked samples
    /// just drop what dereferencing cached (they are already stored).
    pub fn park(&mut self, store: &Arc<dyn SampleStore>) -> std::io::Result<()> {
        match &mut self.0 {
            Repr::Parked(p) => {
                p.cache.take();
                Ok(())
            }
            Repr::Memory(v) => {
                let position = store.put(v)?;
                self.0 = Repr::Parked(Parked {
                    store: store.clone(),
                    position,
                    start: 0,
                    len: v.len(),
                    negate: false,
                    scale: 1.0,
                    cache: OnceLock::new(),
                });
                Ok(())
            }
        }
    }

    /// Frees what dereferencing parked samples cached (no-op in memory).
    pub fn release(&mut self) {
        if let Repr::Parked(p) = &mut self.0 {
            p.cache.take();
        }
    }

    /// The samples, read from the store when parked — without keeping them.
    pub fn load(&self) -> std::io::Result<Cow<'_, [f64]>> {
        match &self.0 {
            Repr::Memory(v) => Ok(Cow::Borrowed(v)),
            Repr::Parked(p) => match p.cache.get() {
                Some(v) => Ok(Cow::Borrowed(v)),
                None => p.read().map(Cow::Owned),
            },
        }
    }

    /// Samples `start..start + len` (as [`Samples::get`]: read from the store
    /// when parked, not kept).  Out-of-range bounds are cut to the samples.
    pub fn get_range(&self, start: usize, len: usize) -> crate::error::Result<Cow<'_, [f64]>> {
        let start = start.min(self.len());
        let end = start.saturating_add(len).min(self.len());
        match &self.0 {
            Repr::Memory(v) => Ok(Cow::Borrowed(&v[start..end])),
            Repr::Parked(p) => match p.cache.get() {
                Some(v) => Ok(Cow::Borrowed(&v[start..end])),
                None => p
                    .read_range(start, end - start)
                    .map(Cow::Owned)
                    .map_err(|e| self.read_error(e)),
            },
        }
    }

    /// Samples `range` as a series of their own (out-of-range bounds cut to
    /// the samples): parked samples give a view of the same stored values,
    /// nothing is read or copied; samples in memory are copied.
    pub fn window(&self, range: std::ops::Range<usize>) -> Samples {
        let end = range.end.min(self.len());
        let start = range.start.min(end);
        match &self.0 {
            Repr::Memory(v) => Samples::new(v[start..end].to_vec()),
            Repr::Parked(p) => Samples(Repr::Parked(p.view(start, end - start, 1.0))),
        }
    }

    /// The samples multiplied by `factor` (each value `v * factor`, as a
    /// units conversion in place computes it): parked samples give a view of
    /// the same stored values, multiplied as they are read; samples in memory
    /// are copied.
    pub fn scaled(&self, factor: f64) -> Samples {
        match &self.0 {
            Repr::Memory(v) => Samples::new(v.iter().map(|x| x * factor).collect()),
            Repr::Parked(p) => Samples(Repr::Parked(p.view(0, p.len, factor))),
        }
    }

    /// As [`Samples::load`], with an error naming the store.
    pub fn get(&self) -> crate::error::Result<Cow<'_, [f64]>> {
        self.load().map_err(|e| self.read_error(e))
    }

    /// As [`Samples::into_vec`], with an error naming the store.
    pub fn take(self) -> crate::error::Result<Vec<f64>> {
        let store = self.store_name();
        self.into_vec().map_err(|e| {
            crate::error::Error::io(format!("{store} (reading back parked samples)"), e)
        })
    }

    fn store_name(&self) -> String {
        match &self.0 {
            Repr::Memory(_) => "memory".into(),
            Repr::Parked(p) => p.store.describe(),
        }
    }

    fn read_error(&self, e: std::io::Error) -> crate::error::Error {
        crate::error::Error::io(
            format!("{} (reading back parked samples)", self.store_name()),
            e,
        )
    }

    /// The samples as a vector (read from the store when parked).
    pub fn into_vec(self) -> std::io::Result<Vec<f64>> {
        match self.0 {
            Repr::Memory(v) => Ok(v),
            Repr::Parked(mut p) => match p.cache.take() {
                Some(v) => Ok(v),
                None => p.read(),
            },
        }
    }

    /// Negates every sample (exact); parked samples are negated when read.
    pub fn negate(&mut self) {
        match &mut self.0 {
            Repr::Memory(v) => v.iter_mut().for_each(|x| *x = -*x),
            Repr::Parked(p) => {
                p.negate = !p.negate;
                if let Some(v) = p.cache.get_mut() {
                    v.iter_mut().for_each(|x| *x = -*x);
                }
            }
        }
    }

    /// The samples as a vector to change in place (brought into memory for good when parked).
    pub fn as_mut_vec(&mut self) -> &mut Vec<f64> {
        if let Repr::Parked(p) = &mut self.0 {
            let v = p.cache.take().unwrap_or_else(|| p.read_or_abort());
            self.0 = Repr::Memory(v);
        }
        match &mut self.0 {
            Repr::Memory(v) => v,
            Repr::Parked(_) => unreachable!("brought into memory above"),
        }
    }
}

impl Default for Samples {
    fn default() -> Self {
        Samples::new(Vec::new())
    }
}

impl From<Vec<f64>> for Samples {
    fn from(values: Vec<f64>) -> Self {
        Samples::new(values)
    }
}

impl std::ops::Deref for Samples {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        match &self.0 {
            Repr::Memory(v) => v,
            Repr::Parked(p) => p.cache.get_or_init(|| p.read_or_abort()),
        }
    }
}

impl std::ops::DerefMut for Samples {
    fn deref_mut(&mut self) -> &mut [f64] {
        self.as_mut_vec()
    }
}

impl Clone for Samples {
    /// Parked samples are shared, not copied (the clone reads the same stored values).
    fn clone(&self) -> Self {
        match &self.0 {
            Repr::Memory(v) => Samples::new(v.clone()),
            Repr::Parked(p) => Samples(Repr::Parked(p.view(0, p.len, 1.0))),
        }
    }
}

impl PartialEq for Samples {
    fn eq(&self, other: &Self) -> bool {
        self[..] == other[..]
    }
}

impl PartialEq<Vec<f64>> for Samples {
    fn eq(&self, other: &Vec<f64>) -> bool {
        self[..] == other[..]
    }
}

impl std::fmt::Debug for Samples {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.0 {
            Repr::Memory(v) => v.fmt(f),
            Repr::Parked(p) => write!(f, "<{} samples parked in {}>", p.len, p.store.describe()),
        }
    }
}

impl FromIterator<f64> for Samples {
    fn from_iter<I: IntoIterator<Item = f64>>(iter: I) -> Self {
        Samples::new(iter.into_iter().collect())
    }
}

impl<const N: usize> PartialEq<[f64; N]> for Samples {
    fn eq(&self, other: &[f64; N]) -> bool {
        self[..] == other[..]
    }
}

impl<'a> IntoIterator for &'a Samples {
    type Item = &'a f64;
    type IntoIter = std::slice::Iter<'a, f64>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}
