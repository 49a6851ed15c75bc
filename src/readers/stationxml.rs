//! FDSN StationXML (1.0 / 1.1): channel metadata for MiniSEED waveforms.
//!
//! StationXML carries no samples.  [`parse`] lists every channel epoch with
//! what quaketwin uses (codes, epoch dates, coordinates, elevation, depth,
//! azimuth, dip, sampling rate, InstrumentSensitivity, sensor description and
//! site name); [`apply`] copies it onto the MiniSEED records of the same
//! event folder.  Parsed with `roxmltree` (small, pure Rust, read-only DOM;
//! namespaces are ignored by matching local tag names, so 1.0 and 1.1 files
//! both read).

use super::{FileContents, ReadOptions};
use crate::error::{Error, Result};
use crate::vocab::{parse_iso8601_ns, Direction, QaFlag, Record, SourceRef, Units};

/// Largest InstrumentSensitivity accepted (counts per input unit); real
/// accelerometer and seismometer gains are below 1e11.
pub const MAX_SENSITIVITY: f64 = 1e15;

/// InstrumentSensitivity of a channel: overall gain at one frequency.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensitivity {
    /// Counts per input unit.
    pub value: f64,
    pub frequency_hz: Option<f64>,
    /// Input units as written (`m/s**2`, `M/S**2`, `M/S`…).
    pub input_units: String,
}

/// One channel epoch of a StationXML file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ChannelMetadata {
    pub network: String,
    pub station: String,
    /// Location code (empty when absent).
    pub location: String,
    pub channel: String,
    /// Epoch start and end, ns since the Unix epoch (None = open).
    pub start_ns: Option<i64>,
    pub end_ns: Option<i64>,
    pub latitude: Option<f64>,
    pub longitude: Option<f64>,
    pub elevation_m: Option<f64>,
    pub depth_m: Option<f64>,
    pub azimuth_deg: Option<f64>,
    pub dip_deg: Option<f64>,
    pub sample_rate_hz: Option<f64>,
    pub sensitivity: Option<Sensitivity>,
    pub sensor_description: Option<String>,
    /// Site name of the station (`<Site><Name>`).
    pub site_name: Option<String>,
    /// File the metadata came from (for the notes `apply` writes).
    pub file: String,
}

impl ChannelMetadata {
    /// `NET.STA.LOC.CHA`, the MiniSEED channel id.
    pub fn id(&self) -> String {
        format!(
            "{}.{}.{}.{}",
            self.network, self.station, self.location, self.channel
        )
    }
    /// Whether `t_ns` lies in this epoch ([start, end), open ends allowed).
    pub fn covers(&self, t_ns: i64) -> bool {
        self.start_ns.is_none_or(|s| t_ns >= s) && self.end_ns.is_none_or(|e| t_ns < e)
    }
}

/// StationXML holds metadata, not samples: this keeps the dispatch semantics
/// of `readers::read` (an input error explaining how the file is used).
pub fn read(_bytes: &[u8], source: &SourceRef, _opts: &ReadOptions) -> Result<FileContents> {
    Err(Error::input(
        super::location(source),
        "StationXML holds metadata, not samples: it is applied to the MiniSEED channels of the same folder",
    ))
}

/// First child element with local name `name`.
fn child<'a, 'i>(n: roxmltree::Node<'a, 'i>, name: &str) -> Option<roxmltree::Node<'a, 'i>> {
    n.children()
        .find(|c| c.is_element() && c.tag_name().name() == name)
}

/// Parses every `Network/Station/Channel` epoch of a StationXML document.
pub fn parse(bytes: &[u8], source: &SourceRef) -> Result<Vec<ChannelMetadata>> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        Error::input(
            super::location(source).at_byte(e.valid_up_to() as u64),
            "StationXML is not UTF-8",
        )
    })?;
    let doc = roxmltree::Document::parse(text).map_err(|e| {
        Error::input(
            super::location(source).at_line(e.pos().row as usize),
            format!("malformed XML: {e}"),
        )
    })?;
    let root = doc.root_element();
    if root.tag_name().name() != "FDSNStationXML" {
        return Err(Error::input(
            super::location(source).at_line(1),
            format!(
                "root element is <{}>, not <FDSNStationXML>",
                root.tag_name().name()
            ),
        ));
    }
    let line_of = |n: roxmltree::Node| doc.text_pos_at(n.range().start).row as usize;
    let err = |n: roxmltree::Node, msg: String| {
        Error::input(super::location(source).at_line(line_of(n)), msg)
    };
    let number = |n: roxmltree::Node, name: &str| -> Result<Option<f64>> {
        match child(n, name) {
            None => Ok(None),
            Some(c) => {
                let t = c.text().unwrap_or("").trim();
                t.parse::<f64>()
                    .map(Some)
                    .map_err(|_| err(c, format!("<{name}> holds {t:?}, not a number")))
            }
        }
    };
    let date = |n: roxmltree::Node, attr: &str| -> Result<Option<i64>> {
        match n.attribute(attr) {
            None => Ok(None),
            Some(t) => parse_iso8601_ns(t)
                .map(Some)
                .ok_or_else(|| err(n, format!("{attr}={t:?} is not an ISO 8601 date"))),
        }
    };
    let code = |n: roxmltree::Node, what: &str| -> Result<String> {
        n.attribute("code")
            .map(|s| s.trim().to_string())
            .ok_or_else(|| err(n, format!("<{what}> without a code attribute")))
    };

    let mut out = Vec::new();
    for net in root
        .children()
        .filter(|c| c.is_element() && c.tag_name().name() == "Network")
    {
        let network = code(net, "Network")?;
        for sta in net
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "Station")
        {
            let station = code(sta, "Station")?;
            let site_name = child(sta, "Site")
                .and_then(|s| child(s, "Name"))
                .and_then(|n| n.text())
                .map(|t| t.trim().to_string());
            for cha in sta
                .children()
                .filter(|c| c.is_element() && c.tag_name().name() == "Channel")
            {
                let sensitivity =
                    match child(cha, "Response").and_then(|r| child(r, "InstrumentSensitivity")) {
                        None => None,
                        Some(s) => {
                            let value = number(s, "Value")?.ok_or_else(|| {
                                err(s, "InstrumentSensitivity without <Value>".into())
                            })?;
                            let input_units = child(s, "InputUnits")
                                .and_then(|u| child(u, "Name"))
                                .and_then(|n| n.text())
                                .map(|t| t.trim().to_string())
                                .unwrap_or_default();
                            Some(Sensitivity {
                                value,
                                frequency_hz: number(s, "Frequency")?,
                                input_units,
                            })
                        }
                    };
                out.push(ChannelMetadata {
                    network: network.clone(),
                    station: station.clone(),
                    location: cha
                        .attribute("locationCode")
                        .unwrap_or("")
                        .trim()
                        .to_string(),
                    channel: code(cha, "Channel")?,
                    start_ns: date(cha, "startDate")?,
                    end_ns: date(cha, "endDate")?,
                    latitude: number(cha, "Latitude")?,
                    longitude: number(cha, "Longitude")?,
                    elevation_m: number(cha, "Elevation")?,
                    depth_m: number(cha, "Depth")?,
                    azimuth_deg: number(cha, "Azimuth")?,
                    dip_deg: number(cha, "Dip")?,
                    sample_rate_hz: number(cha, "SampleRate")?,
                    sensitivity,
                    sensor_description: child(cha, "Sensor")
                        .and_then(|s| child(s, "Description"))
                        .and_then(|n| n.text())
                        .map(|t| t.trim().to_string()),
                    site_name: site_name.clone(),
                    file: source.file.clone(),
                });
            }
        }
    }
    Ok(out)
}

/// Counts per m/s² from a sensitivity whose input units are an acceleration;
/// `None` for other input units (velocity sensors, volts…).
fn counts_per_si(s: &Sensitivity) -> Option<f64> {
    let u = s
        .input_units
        .trim()
        .to_ascii_lowercase()
        .replace("**", "")
        .replace('^', "");
    let per_unit_to_si = match u.as_str() {
        "m/s2" | "m/s/s" | "m/sec2" => 1.0,
        // counts per cm/s² → counts per m/s²: ×100.
        "cm/s2" | "cm/s/s" | "gal" => 100.0,
        "g" => 1.0 / crate::vocab::STANDARD_GRAVITY,
        _ => return None,
    };
    Some(s.value * per_unit_to_si)
}

/// Copies StationXML metadata onto MiniSEED records whose `NET.STA.LOC.CHA`
/// and start time match a channel epoch: sensitivity (as `counts_per_si`, when
/// the input units are an acceleration), direction (azimuth, or Up/Down from
/// a dip of ∓90°), dip, elevation and the site name as `location_text`.
/// Everything applied is noted in the channel's `inferred` list; records of
/// other formats or without a matching epoch are left alone.
pub fn apply(records: &mut [Record], meta: &[ChannelMetadata]) {
    for rec in records.iter_mut() {
        let ch = &mut rec.channel;
        if ch.source.format != "mseed" {
            continue;
        }
        let id = format!(
            "{}.{}.{}.{}",
            ch.network.as_deref().unwrap_or(""),
            ch.station.as_deref().unwrap_or(""),
            ch.location_code.as_deref().unwrap_or(""),
            ch.channel_code.as_deref().unwrap_or("")
        );
        let candidates: Vec<&ChannelMetadata> = meta.iter().filter(|m| m.id() == id).collect();
        let chosen = match ch.start_ns {
            Some(t) => candidates.iter().find(|m| m.covers(t)).copied(),
            None if candidates.len() == 1 => candidates.first().copied(),
            None => None,
        };
        let Some(m) = chosen else { continue };
        let from = format!("from StationXML {} ({id})", m.file);
        if let (
            Units::Counts {
                counts_per_si: None,
            },
            Some(s),
        ) = (ch.units, &m.sensitivity)
        {
            // A gain is a positive finite number of a sane size: −1, INF or
            // 1e300 would scale the records into nonsense, so it is refused
            // and the channel stays without sensitivity (conditioning then
            // stops with an error naming the channel).
            let sane = s.value.is_finite() && s.value > 0.0 && s.value < MAX_SENSITIVITY;
            match counts_per_si(s).filter(|_| sane) {
                None if !sane => ch.qa.push(QaFlag::Note {
                    text: format!(
                        "InstrumentSensitivity {} {from} refused: not a positive gain below {MAX_SENSITIVITY:e}; the channel has no sensitivity",
                        s.value
                    ),
                }),
                Some(c) => {
                    ch.units = Units::Counts {
                        counts_per_si: Some(c),
                    };
                    ch.missing.retain(|x| x != "sensitivity");
                    let f = s
                        .frequency_hz
                        .map(|f| format!(" at {f} Hz"))
                        .unwrap_or_default();
                    ch.inferred.push(format!(
                        "counts_per_si={c} {from}: InstrumentSensitivity {}{f}, input units {}",
                        s.value, s.input_units
                    ));
                }
                None => ch.inferred.push(format!(
                    "sensitivity not applied {from}: input units {:?} are not an acceleration",
                    s.input_units
                )),
            }
        }
        if let Some(dip) = m.dip_deg {
            ch.dip_deg = Some(dip);
            let dir = if (dip + 90.0).abs() < 1e-6 {
                Some(Direction::Up)
            } else if (dip - 90.0).abs() < 1e-6 {
                Some(Direction::Down)
            } else if dip.abs() < 1e-6 {
                m.azimuth_deg
                    .map(|a| Direction::Azimuth(a.rem_euclid(360.0)))
            } else {
                None // inclined sensor: neither horizontal nor vertical; keep the dip only
            };
            if let Some(d) = dir {
                ch.direction = Some(d);
                ch.inferred.push(format!(
                    "direction={d} {from}: azimuth {} dip {dip}",
                    m.azimuth_deg
                        .map(|a| a.to_string())
                        .unwrap_or_else(|| "-".into())
                ));
            }
        }
        if let Some(e) = m.elevation_m {
            ch.elevation_m = Some(e);
            let depth = m
                .depth_m
                .map(|d| format!(", depth {d} m"))
                .unwrap_or_default();
            ch.inferred.push(format!("elevation_m={e} {from}{depth}"));
        }
        if let Some(site) = &m.site_name {
            ch.location_text = Some(site.clone());
            ch.inferred
                .push(format!("location_text={site:?} {from} (site name)"));
        }
        if let Some(r) = m.sample_rate_hz {
            if (r - ch.sampling_rate_hz).abs() > 1e-6 * r.abs().max(1.0) {
                ch.qa.push(crate::vocab::QaFlag::Note {
                    text: format!(
                        "StationXML sample rate {r} Hz differs from the data's {} Hz",
                        ch.sampling_rate_hz
                    ),
                });
            }
        }
    }
}
