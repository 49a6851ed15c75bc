//! `quaketwin init EVENT`: the `event.toml` of what was read and inferred
//! from the headers (event, structure, one `[[channel]]` per channel), with
//! what is still unknown as commented fields, so a user starts from a
//! complete manifest instead of a blank one.  The text parses with
//! [`Manifest::parse`](super::Manifest::parse) and, placed in the event
//! folder, loads to the same levels, roles and directions.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use super::LoadedEvent;
use crate::vocab::{format_epoch_ns, Direction, Record, Role, Units};

/// TOML string literal (quoted, escaped).
fn quoted(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

/// The manifest's `file` for a record: relative to the event's root — the
/// zip member for a zip given as the event (`zip_event`), else `file` or
/// `bundle.zip:member` as `quaketwin inspect` lists files.
fn file_of(r: &Record, zip_event: bool) -> String {
    match &r.channel.source.member {
        Some(m) if zip_event => m.clone(),
        Some(m) => format!("{}:{m}", r.channel.source.file),
        None => r.channel.source.file.clone(),
    }
}

fn direction_value(d: Direction) -> String {
    match d {
        Direction::Azimuth(a) => format!("{a}"),
        other => quoted(&other.to_string()),
    }
}

/// The `column` picking a record in a file of several: its location code or
/// channel code when unique in the file, else its index.
fn column_of(r: &Record, same_file: &[&Record], index: usize) -> String {
    let unique = |f: &dyn Fn(&Record) -> Option<String>| {
        let mine = f(r)?;
        let clash = same_file
            .iter()
            .filter(|o| f(o).as_deref() == Some(mine.as_str()))
            .count();
        // An all-digit code could be read as an index: quoted it is a name.
        (clash == 1).then(|| quoted(&mine))
    };
    unique(&|x: &Record| x.channel.location_code.clone())
        .or_else(|| unique(&|x: &Record| x.channel.channel_code.clone()))
        .unwrap_or_else(|| index.to_string())
}

/// The manifest text for `loaded` (from [`super::load_headers`]: directions
/// as the headers give them, before the building geometry); `zip_event`:
/// the event is a zip file (paths are its members).
pub fn manifest_text(loaded: &LoadedEvent, source: &str, zip_event: bool) -> String {
    let e = &loaded.event;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# event.toml written by `quaketwin init` from the headers of {source}.\n# Values were read or inferred (`quaketwin inspect` says how); check them.\n# Commented fields are unknown: state them to unlock what they say.\n"
    );
    let _ = writeln!(s, "[event]\nname = {}", quoted(&e.name));
    match e.origin_ns {
        Some(t) => {
            let _ = writeln!(s, "origin_time = {}", quoted(&format_epoch_ns(t)));
        }
        None => s.push_str("# origin_time = \"2020-01-01T00:00:00Z\"  # unknown\n"),
    }
    if let Some(m) = e.magnitude {
        let _ = writeln!(s, "magnitude = {m}");
    }
    match &e.hypocentre {
        Some(h) => {
            let _ = writeln!(
                s,
                "latitude_deg = {}\nlongitude_deg = {}",
                h.latitude_deg, h.longitude_deg
            );
            if let Some(d) = h.depth_km {
                let _ = writeln!(s, "depth_km = {d:?}");
            }
        }
        None => s.push_str("# latitude_deg = 34.21  # unknown: epicentre (WGS 84), for the report's epicentral distance\n# longitude_deg = -118.54\n"),
    }
    let st = e.structure.clone().unwrap_or_default();
    s.push_str("\n[structure]\n");
    for i in &st.inferred {
        let _ = writeln!(s, "# inferred: {i}");
    }
    if let Some(n) = &st.name {
        let _ = writeln!(s, "name = {}", quoted(n));
    }
    match &st.kind {
        Some(k) => {
            let _ = writeln!(s, "kind = {}", quoted(k));
        }
        None => s.push_str("# kind = \"building\"  # unknown: building or bridge\n"),
    }
    match st.storeys {
        Some(n) => {
            let _ = writeln!(s, "storeys = {n}");
        }
        None => s.push_str("# storeys = 7  # unknown: the roof is level `storeys`\n"),
    }
    match st.height_m {
        Some(h) => {
            let _ = writeln!(s, "height_m = {h}");
        }
        None => s.push_str("# height_m = 21.0  # unknown: total height above the base, metres\n"),
    }
    if st.storey_heights_m.is_empty() {
        s.push_str("# storey_heights_m = [...]  # unknown: state them for drift ratios (one per storey, level 1..n, metres)\n");
    } else {
        let _ = writeln!(s, "storey_heights_m = {:?}", st.storey_heights_m);
    }
    if st.masses_kg.is_empty() {
        s.push_str("# masses_kg = [...]  # unknown: lumped mass per level 1..n, kg (Bouc-Wen identification)\n");
    } else {
        let _ = writeln!(s, "masses_kg = {:?}", st.masses_kg);
    }
    match &st.building_type {
        Some(t) => {
            let _ = writeln!(s, "type = {}", quoted(t));
        }
        None => s.push_str("# type = \"C1\"  # unknown: model building type (HAZUS code: C1, C2, S1, W1, PC1, RM1, URM…), its drift fragility\n"),
    }
    match &st.design_level {
        Some(t) => {
            let _ = writeln!(s, "design_level = {}", quoted(t));
        }
        None => s.push_str("# design_level = \"moderate\"  # unknown: HAZUS seismic design level (high, moderate, low, pre)\n"),
    }
    match st.x_axis_azimuth_deg {
        Some(a) => {
            let _ = writeln!(s, "x_axis_azimuth_deg = {a}");
        }
        None => s.push_str(
            "# x_axis_azimuth_deg = 0.0  # not stated: inferred from the sensor azimuths at load\n",
        ),
    }
    match (st.latitude_deg, st.longitude_deg) {
        (Some(lat), Some(lon)) => {
            let _ = writeln!(s, "latitude_deg = {lat}\nlongitude_deg = {lon}");
        }
        _ => match e.station_position {
            // The station is usually at the structure: offered, not stated.
            Some([lat, lon]) => {
                let _ = writeln!(
                    s,
                    "# latitude_deg = {lat}  # the recording station's position (record headers): state the structure's\n# longitude_deg = {lon}"
                );
            }
            None => s.push_str("# latitude_deg = 34.05  # unknown: position (WGS 84, north and east positive), for the fleet dashboard's map\n# longitude_deg = -118.25\n"),
        },
    }
    if let Some(t) = &st.twin {
        let _ = writeln!(s, "twin = {}", quoted(t));
    }

    let sensors: Vec<&Record> = e
        .records
        .iter()
        .filter(|r| r.channel.combines.is_empty())
        .collect();
    let mut by_file: BTreeMap<String, Vec<&Record>> = BTreeMap::new();
    for r in &sensors {
        by_file.entry(file_of(r, zip_event)).or_default().push(r);
    }
    for r in &sensors {
        let c = &r.channel;
        let file = file_of(r, zip_event);
        let same_file = &by_file[&file];
        s.push_str("\n[[channel]]\n");
        let _ = writeln!(s, "file = {}", quoted(&file));
        if same_file.len() > 1 {
            let index = same_file
                .iter()
                .position(|o| std::ptr::eq(*o, *r))
                .unwrap_or(0);
            let _ = writeln!(s, "column = {}", column_of(r, same_file, index));
        }
        let _ = writeln!(s, "id = {}", quoted(&c.id));
        match c.level {
            Some(l) => {
                let _ = writeln!(s, "level = {l}");
            }
            None => s.push_str("# level = 0  # unknown: 0 = base, n = storey n\n"),
        }
        match c.direction {
            Some(d) => {
                let _ = writeln!(s, "direction = {}", direction_value(d));
            }
            None => s.push_str("# direction = \"X\"  # unknown\n"),
        }
        match c.role {
            Role::Input => s.push_str("role = \"input\"\n"),
            Role::Output => s.push_str("role = \"output\"\n"),
            Role::Unknown => {
                s.push_str("# role = \"output\"  # unknown: input (base, ground) or output\n")
            }
        }
        let _ = writeln!(s, "units = {}", quoted(c.units.name()));
        if let Units::Counts { counts_per_si } = c.units {
            match counts_per_si {
                Some(k) => {
                    let _ = writeln!(s, "sensitivity = {k}");
                }
                None => s.push_str("# sensitivity = 1.0  # unknown: counts per m/s²\n"),
            }
        }
        if let Some(t) = &c.location_text {
            let _ = writeln!(s, "# location in the header: {}", t.replace('\n', " "));
        }
    }
    s
}
