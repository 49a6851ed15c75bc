//! The structure from what the networks publish: levels and the kind of
//! structure read from the sensors' location text (SMC `<loclbl=Roof>`,
//! CSMIP/COSMOS `Location: 4th Floor`), the storey count from the station
//! name ("Van Nuys - 7-story Hotel"), the kind from a COSMOS structure-type
//! code.  Each inference is recorded (`Channel::inferred`,
//! `Structure::inferred`) and a stated value (event.toml) always wins.
//!
//! Level convention (docs/event-folder.md): level 0 = the base (basement,
//! ground, foundation, "1st floor"); "Nth floor" = level N − 1 (the US
//! convention of CSMIP and NSMP: the 1st floor is the ground floor); the
//! roof = level `storeys`; a penthouse = `storeys + 1`.  When one structure
//! has both a "Ground floor" and a "1st floor" sensor, the floors count from
//! the ground floor (British/European convention: "Nth floor" = level N).
//! Free-field sensors
//! have no level.  Bridges (deck, abutments, piers) get no levels.

use crate::vocab::Event;

/// Where a location text puts a sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Place {
    /// Basement, ground floor, foundation…: level 0 (the word that decided).
    Base(&'static str),
    /// "Nth floor" / "floor N" / "level N" as labelled (level N − 1).
    Floor(u32),
    Roof,
    Penthouse,
    /// Between two floors: no whole level (state `level` in event.toml).
    Mezzanine,
    FreeField,
    /// A bridge part (deck, abutment, pier…): no level.
    Bridge(&'static str),
}

impl Place {
    /// Short upper-case tag appended to channel ids ("ROOF", "FLOOR4").
    pub fn tag(&self) -> String {
        match self {
            Place::Base(w) => w.replace(' ', ""),
            Place::Floor(n) => format!("FLOOR{n}"),
            Place::Roof => "ROOF".into(),
            Place::Penthouse => "PENTHOUSE".into(),
            Place::Mezzanine => "MEZZANINE".into(),
            Place::FreeField => "FREEFIELD".into(),
            Place::Bridge(w) => w.replace(' ', ""),
        }
    }
}

const ORDINAL_WORDS: [&str; 20] = [
    "FIRST",
    "SECOND",
    "THIRD",
    "FOURTH",
    "FIFTH",
    "SIXTH",
    "SEVENTH",
    "EIGHTH",
    "NINTH",
    "TENTH",
    "ELEVENTH",
    "TWELFTH",
    "THIRTEENTH",
    "FOURTEENTH",
    "FIFTEENTH",
    "SIXTEENTH",
    "SEVENTEENTH",
    "EIGHTEENTH",
    "NINETEENTH",
    "TWENTIETH",
];
const NUMBER_WORDS: [&str; 20] = [
    "ONE",
    "TWO",
    "THREE",
    "FOUR",
    "FIVE",
    "SIX",
    "SEVEN",
    "EIGHT",
    "NINE",
    "TEN",
    "ELEVEN",
    "TWELVE",
    "THIRTEEN",
    "FOURTEEN",
    "FIFTEEN",
    "SIXTEEN",
    "SEVENTEEN",
    "EIGHTEEN",
    "NINETEEN",
    "TWENTY",
];
const FLOOR_WORDS: [&str; 5] = ["FLOOR", "FLR", "FL", "LEVEL", "LVL"];
const BRIDGE_WORDS: [&str; 7] = [
    "DECK",
    "ABUTMENT",
    "PIER",
    "BENT",
    "GIRDER",
    "SPAN",
    "EMBANKMENT",
];
const BASE_WORDS: [(&str, &str); 8] = [
    ("SUB-BASEMENT", "BASEMENT"),
    ("SUBBASEMENT", "BASEMENT"),
    ("BASEMENT", "BASEMENT"),
    ("FOUNDATION", "FOUNDATION"),
    ("GROUND", "GROUND"),
    ("GRND", "GROUND"),
    ("BASE", "BASE"),
    ("LOBBY", "GROUND"),
];

/// Upper-case words of a text, split on anything but letters, digits and `-`.
fn words(text: &str) -> Vec<String> {
    text.to_ascii_uppercase()
        .split(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
        .filter(|w| !w.is_empty())
        .map(str::to_string)
        .collect()
}

/// A floor number written as `4`, `4th`, `4TH`, `1st`, `Fourth`.
fn floor_number(word: &str) -> Option<u32> {
    let w = word.trim_matches('-');
    let digits: String = w.chars().take_while(|c| c.is_ascii_digit()).collect();
    if !digits.is_empty() {
        let rest = &w[digits.len()..];
        return (rest.is_empty() || ["ST", "ND", "RD", "TH"].contains(&rest))
            .then(|| digits.parse().ok())
            .flatten();
    }
    ORDINAL_WORDS
        .iter()
        .position(|o| *o == w)
        .map(|i| i as u32 + 1)
}

/// Reads where a sensor is from its location text; `None` when the text
/// names no place this module knows (the role may still come from
/// `role_from_location_text`).
pub fn place_from_text(text: &str) -> Option<Place> {
    let upper = text.to_ascii_uppercase();
    if ["FREE FIELD", "FREEFIELD", "FREE-FIELD"]
        .iter()
        .any(|w| upper.contains(w))
    {
        return Some(Place::FreeField);
    }
    let ws = words(text);
    let has = |w: &str| ws.iter().any(|x| x == w || x.starts_with(&format!("{w}-")));
    if let Some(w) = BRIDGE_WORDS
        .iter()
        .find(|w| ws.iter().any(|x| x.starts_with(*w)))
    {
        return Some(Place::Bridge(w));
    }
    if has("PENTHOUSE") {
        return Some(Place::Penthouse);
    }
    if has("ROOF") {
        return Some(Place::Roof);
    }
    if ws.iter().any(|w| w.starts_with("MEZZ")) {
        return Some(Place::Mezzanine);
    }
    // "4th Floor", "4th Flr", "Fourth floor", "Floor 4", "Level 3", "3rd Level".
    for (k, w) in ws.iter().enumerate() {
        if !FLOOR_WORDS.contains(&w.as_str()) {
            continue;
        }
        let before = k.checked_sub(1).and_then(|j| floor_number(&ws[j]));
        let after = ws.get(k + 1).and_then(|n| floor_number(n));
        if let Some(n) = before.or(after).filter(|&n| n >= 1) {
            return Some(Place::Floor(n));
        }
    }
    BASE_WORDS
        .iter()
        .find(|(w, _)| ws.iter().any(|x| x == w || x.starts_with(&format!("{w}-"))))
        .map(|(_, tag)| Place::Base(tag))
}

/// The storey count a station name states: "7-story", "52-story",
/// "12-storey", "7 story", "Seven-story", "10 stories".  `None` when the
/// name states none.
pub fn storeys_from_name(name: &str) -> Option<u32> {
    let ws: Vec<String> = name
        .to_ascii_uppercase()
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| !w.is_empty())
        .map(str::to_string)
        .collect();
    let is_storey = |w: &str| matches!(w, "STORY" | "STOREY" | "STORIES" | "STOREYS" | "STY");
    ws.windows(2).find_map(|p| {
        if !is_storey(&p[1]) {
            return None;
        }
        let n = p[0].parse::<u32>().ok().or_else(|| {
            NUMBER_WORDS
                .iter()
                .position(|w| *w == p[0])
                .map(|i| i as u32 + 1)
        })?;
        (1..=300).contains(&n).then_some(n)
    })
}

/// A height a header states in words: "height 30.5 m", "height = 100 ft",
/// "<height=30m>".  Feet are converted to metres (0.3048 m/ft).
pub fn height_from_text(text: &str) -> Option<f64> {
    let upper = text.to_ascii_uppercase();
    let p = upper.find("HEIGHT")?;
    let rest = upper[p + 6..].trim_start_matches([' ', '=', ':']);
    let num: String = rest
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '.')
        .collect();
    let value: f64 = num.parse().ok()?;
    let unit = rest[num.len()..].trim_start();
    let metres = if unit.starts_with("FT") || unit.starts_with("FEET") {
        value * 0.3048
    } else if unit.starts_with('M') {
        value
    } else {
        return None;
    };
    (metres > 0.0 && metres < 1000.0).then_some(metres)
}

/// What the headers say about the structure, gathered by the event folder.
#[derive(Debug, Clone, Default)]
pub struct HeaderFacts {
    /// Station names as the files give them (deduplicated, in file order).
    pub station_names: Vec<String>,
    /// Kinds stated by header fields, with the field ("building", "COSMOS …").
    pub stated_kinds: Vec<(String, String)>,
}

const BRIDGE_NAMES: [&str; 5] = [
    "BRIDGE",
    "OVERPASS",
    "VIADUCT",
    "OVERCROSSING",
    "INTERCHANGE",
];
const BUILDING_NAMES: [&str; 6] = ["BLDG", "BUILDING", "HOTEL", "OFFICE", "HOSPITAL", "STORY"];

/// Fills levels (buildings only), ids carrying the location, and the
/// structure (storeys, height, kind) from the headers, recording each
/// inference.  `tag_ids`: append the location to channel ids (not when the
/// manifest lists the channels).  Returns the event notes to add.
pub fn infer_structure(event: &mut Event, facts: &HeaderFacts, tag_ids: bool) -> Vec<String> {
    let mut notes = Vec::new();
    let places: Vec<Option<Place>> = event
        .records
        .iter()
        .map(|r| r.channel.location_text.as_deref().and_then(place_from_text))
        .collect();
    let names_upper: Vec<String> = facts
        .station_names
        .iter()
        .map(|n| n.to_ascii_uppercase())
        .collect();

    // Kind: stated by a header field, else from the sensors' places, else
    // from the station name.  A bridge part anywhere makes it a bridge.
    let kind_stated = facts.stated_kinds.first().cloned();
    let bridge_place = places.iter().flatten().find_map(|p| match p {
        Place::Bridge(w) => Some(*w),
        _ => None,
    });
    let building_place = places.iter().flatten().find(|p| {
        matches!(
            p,
            Place::Floor(_) | Place::Roof | Place::Penthouse | Place::Mezzanine
        ) || matches!(p, Place::Base("BASEMENT"))
    });
    let named = |words: &[&'static str]| -> Option<(String, &'static str)> {
        names_upper.iter().find_map(|n| {
            words
                .iter()
                .find(|w| n.contains(**w))
                .map(|w| (n.clone(), *w))
        })
    };
    let (kind, kind_how) = if let Some((k, how)) = kind_stated {
        (Some(k), how)
    } else if let Some(w) = bridge_place {
        (
            Some("bridge".to_string()),
            format!("a sensor location names a bridge part ({w:?})"),
        )
    } else if let Some((n, w)) = named(&BRIDGE_NAMES) {
        (
            Some("bridge".into()),
            format!("station name {n:?} contains {w:?}"),
        )
    } else if let Some(p) = building_place {
        (
            Some("building".into()),
            format!("a sensor location names a building level ({})", p.tag()),
        )
    } else if let Some((n, w)) = named(&BUILDING_NAMES) {
        (
            Some("building".into()),
            format!("station name {n:?} contains {w:?}"),
        )
    } else {
        (None, String::new())
    };

    let structure_stated = event.structure.is_some();
    let mut st = event.structure.clone().unwrap_or_default();
    let mut changed = false;
    if st.kind.is_none() {
        if let Some(k) = &kind {
            st.kind = Some(k.clone());
            st.inferred.push(format!("kind={k} from {kind_how}"));
            changed = true;
        }
    }
    if st.storeys.is_none() {
        if let Some((n, name)) = facts
            .station_names
            .iter()
            .find_map(|s| storeys_from_name(s).map(|n| (n, s)))
        {
            st.storeys = Some(n);
            st.inferred
                .push(format!("storeys={n} from station name {name:?}"));
            changed = true;
        }
    }
    if st.height_m.is_none() {
        if let Some((h, name)) = facts
            .station_names
            .iter()
            .find_map(|s| height_from_text(s).map(|h| (h, s)))
        {
            st.height_m = Some(h);
            st.inferred
                .push(format!("height_m={h} from station name {name:?}"));
            changed = true;
        }
    }
    if st.name.is_none() && changed {
        st.name = facts.station_names.first().cloned();
    }
    let is_building = st.kind.as_deref() == Some("building");

    // Levels: buildings only (a bridge's "ground" sensor is no storey).
    let mut levels: Vec<Option<(i32, String)>> = vec![None; places.len()];
    if is_building {
        // A "Ground floor" sensor beside a "1st floor" one: the two are not
        // the same slab, so the floors count from the ground floor (the
        // British/European convention: the 1st floor is one storey up).
        let european = places.iter().flatten().any(|p| *p == Place::Base("GROUND"))
            && places.iter().flatten().any(|p| *p == Place::Floor(1));
        let floor_level = |n: u32| if european { n as i32 } else { n as i32 - 1 };
        let floor_top = places
            .iter()
            .flatten()
            .filter_map(|p| match p {
                Place::Floor(n) => Some(floor_level(*n)),
                _ => None,
            })
            .max();
        let has_roof = places
            .iter()
            .flatten()
            .any(|p| matches!(p, Place::Roof | Place::Penthouse));
        let roof = match st.storeys {
            Some(n) => Some((n as i32, format!("roof = level storeys = {n}"))),
            None if has_roof => {
                let l = floor_top.map_or(1, |t| t + 1);
                let rule = match floor_top {
                    Some(t) => format!("ASSUMED: storey count unknown, roof = highest labelled floor level ({t}) + 1 = {l}"),
                    None => "ASSUMED: storey count unknown and no labelled floor, roof = level 1".to_string(),
                };
                notes.push(format!(
                    "roof level {l} assumed ({rule}); state structure.storeys in event.toml"
                ));
                Some((l, rule))
            }
            None => None,
        };
        if let (Some(n), Some(t)) = (st.storeys, floor_top) {
            if t >= n as i32 {
                notes.push(format!("a labelled floor is level {t}, at or above the roof (storeys = {n}): check the storey count"));
            }
        }
        for (k, p) in places.iter().enumerate() {
            levels[k] = match p {
                Some(Place::Base(w)) => Some((0, format!("{w} = level 0 (the base)"))),
                Some(Place::Floor(n)) if european => Some((
                    floor_level(*n),
                    format!(
                        "floor {n} = level {n} (a ground-floor and a 1st-floor sensor: the 1st floor is one storey above the ground floor)"
                    ),
                )),
                Some(Place::Floor(n)) => Some((
                    floor_level(*n),
                    format!(
                        "floor {n} = level {} (US convention: the 1st floor is the ground floor)",
                        floor_level(*n)
                    ),
                )),
                Some(Place::Roof) => roof.clone(),
                Some(Place::Penthouse) => roof
                    .as_ref()
                    .map(|(l, how)| (l + 1, format!("penthouse = roof level + 1 ({how})"))),
                _ => None,
            };
        }
    }
    for ((r, p), lv) in event.records.iter_mut().zip(&places).zip(levels) {
        let ch = &mut r.channel;
        let text = ch.location_text.clone().unwrap_or_default();
        if ch.level.is_none() {
            if let Some((l, how)) = lv {
                ch.level = Some(l);
                ch.inferred
                    .push(format!("level={l} from location {:?}: {how}", text.trim()));
            } else if is_building && matches!(p, Some(Place::Mezzanine)) {
                notes.push(format!(
                    "channel {}: a mezzanine has no whole level; state `level` in event.toml",
                    ch.id
                ));
            }
        }
        if tag_ids && is_building {
            if let Some(p) = p {
                let tag = p.tag();
                if !ch.id.to_ascii_uppercase().ends_with(&tag) {
                    let old = ch.id.clone();
                    ch.id = format!("{old}.{tag}");
                    ch.inferred.push(format!(
                        "id {} = header id {old} + location {:?}",
                        ch.id,
                        text.trim()
                    ));
                }
            }
        }
    }
    if changed {
        if !structure_stated {
            notes.push(format!(
                "no [structure] section in event.toml: structure inferred from the headers ({})",
                st.inferred.join("; ")
            ));
        }
        event.structure = Some(st);
    }
    notes
}
