//! The StationXML of a tracking run (docs/monitoring.md, "Reading the
//! archive"): counts → m/s² and direction labels per stream, taken from the
//! channel epoch (`<Channel startDate endDate>`) that holds each window's
//! start, so a sensor replaced or re-gained during the archive is calibrated
//! with the response of its time.  A window whose start no epoch of some
//! stream covers is skipped with the reason; a window across an epoch
//! change is identified with the response of its start and carries a note.

use std::path::{Path, PathBuf};

use crate::error::{Error, Location, Result};
use crate::readers::mseed::StreamCodes;
use crate::readers::stationxml::{self, ChannelMetadata};
use crate::vocab::{format_epoch_ns, Channel, Record, SourceRef, Units};

/// Per stream: factor from counts to physical units, direction label, group.
#[derive(Clone)]
pub struct StreamCalibration {
    pub scale: Vec<f64>,
    pub directions: Vec<String>,
    pub groups: Vec<String>,
    pub units: String,
}

fn groups(streams: &[StreamCodes]) -> Vec<String> {
    streams
        .iter()
        .map(|c| format!("{}.{}", c.station, c.location))
        .collect()
}

/// Without StationXML: counts, no direction labels (said once on stderr).
pub fn uncalibrated(streams: &[StreamCodes]) -> StreamCalibration {
    crate::console::warn(
        "track: no StationXML (--stationxml): samples stay in counts, channel orientations are unknown (modes without direction labels); frequencies and damping are unaffected, shapes assume equal gains",
    );
    StreamCalibration {
        scale: vec![1.0; streams.len()],
        directions: vec![String::new(); streams.len()],
        groups: groups(streams),
        units: "counts".into(),
    }
}

/// The run's StationXML: every channel epoch, parsed once.
pub struct Responses {
    path: PathBuf,
    meta: Vec<ChannelMetadata>,
}

impl Responses {
    /// Reads and parses `path`; every stream needs an acceleration
    /// sensitivity in at least one of its epochs (else an input error naming
    /// the file and the streams: leave `--stationxml` out to work in counts).
    pub fn load(path: &Path, streams: &[StreamCodes]) -> Result<Responses> {
        let bytes = crate::input_file::read(path, crate::input_file::MAX_INPUT_BYTES)?;
        let source = SourceRef {
            file: path.display().to_string(),
            member: None,
            column: None,
            format: "stationxml".into(),
        };
        let r = Responses {
            path: path.to_path_buf(),
            meta: stationxml::parse(&bytes, &source)?,
        };
        let missing: Vec<String> = streams
            .iter()
            .filter(|c| {
                !r.epochs(c).any(|m| {
                    let t = m.start_ns.or(m.end_ns.map(|e| e - 1)).unwrap_or(0);
                    r.gain(c, t).is_some()
                })
            })
            .map(StreamCodes::id)
            .collect();
        if !missing.is_empty() {
            return Err(r.no_gain(&missing, "in any epoch"));
        }
        Ok(r)
    }

    fn epochs<'a>(&'a self, c: &StreamCodes) -> impl Iterator<Item = &'a ChannelMetadata> {
        let id = c.id();
        self.meta.iter().filter(move |m| m.id() == id)
    }

    fn no_gain(&self, streams: &[String], when: &str) -> Error {
        Error::input(
            Location::file(self.path.display().to_string()),
            format!(
                "no acceleration sensitivity for {} {when}: every tracked stream needs its gain (or leave --stationxml out to work in counts)",
                streams.join(", ")
            ),
        )
    }

    /// Stream `c` as a channel starting at `t_ns`, with the StationXML
    /// applied (`stationxml::apply`, as for event folders: the epoch
    /// containing `t_ns`).
    fn channel_at(&self, c: &StreamCodes, t_ns: i64) -> Channel {
        let src = SourceRef {
            file: self.path.display().to_string(),
            member: None,
            column: None,
            format: "mseed".into(),
        };
        let mut ch = Channel::new(
            c.id(),
            Units::Counts {
                counts_per_si: None,
            },
            1.0,
            src,
        );
        ch.network = Some(c.network.clone());
        ch.station = Some(c.station.clone());
        ch.location_code = Some(c.location.clone());
        ch.channel_code = Some(c.channel.clone());
        ch.start_ns = Some(t_ns);
        let mut rec = [Record::new(ch, Vec::new())];
        stationxml::apply(&mut rec, &self.meta);
        let [rec] = rec;
        rec.channel
    }

    fn gain(&self, c: &StreamCodes, t_ns: i64) -> Option<f64> {
        match self.channel_at(c, t_ns).units {
            Units::Counts {
                counts_per_si: Some(g),
            } => Some(g),
            _ => None,
        }
    }

    /// The calibration of a window starting at `t_ns`: each stream's epoch
    /// containing `t_ns`.  An input error naming the file, the streams
    /// without an acceleration sensitivity there and the time.
    pub fn at(&self, streams: &[StreamCodes], t_ns: i64) -> Result<StreamCalibration> {
        let mut scale = Vec::new();
        let mut directions = Vec::new();
        let mut missing = Vec::new();
        for c in streams {
            let ch = self.channel_at(c, t_ns);
            match ch.units {
                Units::Counts {
                    counts_per_si: Some(g),
                } => scale.push(1.0 / g),
                _ => missing.push(c.id()),
            }
            directions.push(crate::modal::direction_label(&ch));
        }
        if !missing.is_empty() {
            let when = format!(
                "at {} (no StationXML epoch with one holds that time)",
                format_epoch_ns(t_ns)
            );
            return Err(self.no_gain(&missing, &when));
        }
        Ok(StreamCalibration {
            scale,
            directions,
            groups: groups(streams),
            units: "m/s^2".into(),
        })
    }

    /// Notes for the streams whose epoch changes within [t0, t1): the
    /// window is calibrated with the response at its start.
    pub fn epoch_changes(&self, streams: &[StreamCodes], t0: i64, t1: i64) -> Vec<String> {
        let mut notes = Vec::new();
        for c in streams {
            let covering = |t: i64| self.epochs(c).position(|m| m.covers(t));
            if covering(t0) == covering(t1 - 1) {
                continue;
            }
            let change = self
                .epochs(c)
                .flat_map(|m| [m.start_ns, m.end_ns])
                .flatten()
                .filter(|&t| t > t0 && t < t1)
                .min()
                .unwrap_or(t1);
            notes.push(format!(
                "StationXML epoch of {} changes at {} within the window: the response of the epoch at the window's start is used for the whole window ({})",
                c.id(),
                format_epoch_ns(change),
                self.path.display()
            ));
        }
        notes
    }
}

/// How the counts of a run become physical units.
pub enum Calibration {
    /// No StationXML: counts, no direction labels.
    Counts(StreamCalibration),
    StationXml(Responses),
}

impl Calibration {
    /// From `--stationxml` (checked: every stream has a gain in some epoch).
    pub fn new(streams: &[StreamCodes], xml: Option<&Path>) -> Result<Calibration> {
        Ok(match xml {
            None => Calibration::Counts(uncalibrated(streams)),
            Some(path) => Calibration::StationXml(Responses::load(path, streams)?),
        })
    }

    pub fn units(&self) -> &'static str {
        match self {
            Calibration::Counts(_) => "counts",
            Calibration::StationXml(_) => "m/s^2",
        }
    }

    /// The calibration of the window starting at `t_ns` (module doc).
    pub fn at(&self, streams: &[StreamCodes], t_ns: i64) -> Result<StreamCalibration> {
        match self {
            Calibration::Counts(c) => Ok(c.clone()),
            Calibration::StationXml(r) => r.at(streams, t_ns),
        }
    }

    /// Notes of the epoch changes within [t0, t1) (module doc).
    pub fn epoch_changes(&self, streams: &[StreamCodes], t0: i64, t1: i64) -> Vec<String> {
        match self {
            Calibration::Counts(_) => Vec::new(),
            Calibration::StationXml(r) => r.epoch_changes(streams, t0, t1),
        }
    }
}
