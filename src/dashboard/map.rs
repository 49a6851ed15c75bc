//! The dashboard's map: the structures with a stated position as dots in
//! an inline SVG, coloured by their latest rating and linked to their
//! pages.  No tiles, no network: longitude and latitude on an
//! equirectangular projection whose x is scaled by cos(mean latitude), so
//! that distances east–west and north–south look alike near the fleet,
//! with a graticule labelled in degrees.

use crate::report::escape;

/// Width and height of the drawing, px.
const WIDTH: f64 = 720.0;
const HEIGHT: f64 = 420.0;
const MARGIN: f64 = 48.0;
/// Smallest span shown, degrees (one structure alone sits in ≈ 10 km).
const MIN_SPAN_DEG: f64 = 0.1;

/// One dot.
pub struct Place {
    pub key: String,
    pub label: String,
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    pub rating: String,
    /// Link to the structure's page (relative to the page holding the map).
    pub href: String,
}

/// CSS class of a rating's dot (the colours of the report's badges).
fn dot_class(rating: &str) -> &'static str {
    match rating {
        "GREEN" => "dot r-green",
        "YELLOW" => "dot r-yellow",
        "ORANGE" => "dot r-orange",
        "RED" => "dot r-red",
        _ => "dot r-none",
    }
}

/// A graticule step of about five lines across `span` degrees.
fn step_for(span: f64) -> f64 {
    let raw = span / 5.0;
    let p = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * p)
}

/// The map's `<svg>`, or None when no place is given.
pub fn svg(places: &[Place]) -> Option<String> {
    if places.is_empty() {
        return None;
    }
    let lats = places.iter().map(|p| p.latitude_deg);
    let lons = places.iter().map(|p| p.longitude_deg);
    let (lat0, lat1) = lats.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let (lon0, lon1) = lons.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let aspect = ((lat0 + lat1) / 2.0).to_radians().cos().max(0.05);
    // Spans with a margin of 10 % (and at least MIN_SPAN_DEG).
    let lat_span = ((lat1 - lat0) * 1.2).max(MIN_SPAN_DEG);
    let lon_span = ((lon1 - lon0) * 1.2).max(MIN_SPAN_DEG / aspect);
    let (lat_mid, lon_mid) = ((lat0 + lat1) / 2.0, (lon0 + lon1) / 2.0);
    // One scale, px per degree of latitude, fitting both spans.
    let scale =
        ((WIDTH - 2.0 * MARGIN) / (lon_span * aspect)).min((HEIGHT - 2.0 * MARGIN) / lat_span);
    let x = |lon: f64| WIDTH / 2.0 + (lon - lon_mid) * aspect * scale;
    let y = |lat: f64| HEIGHT / 2.0 - (lat - lat_mid) * scale;
    let (west, east) = (
        lon_mid - (WIDTH / 2.0) / (aspect * scale),
        lon_mid + (WIDTH / 2.0) / (aspect * scale),
    );
    let (south, north) = (
        lat_mid - (HEIGHT / 2.0) / scale,
        lat_mid + (HEIGHT / 2.0) / scale,
    );
    let mut s = format!(
        "<svg class=\"map\" viewBox=\"0 0 {WIDTH} {HEIGHT}\" width=\"{WIDTH}\" height=\"{HEIGHT}\" role=\"img\" aria-label=\"map of the structures\">\n<rect x=\"0\" y=\"0\" width=\"{WIDTH}\" height=\"{HEIGHT}\" class=\"map-bg\"/>\n"
    );
    let digits = |step: f64| (-step.log10().floor()).max(0.0) as usize;
    let lon_step = step_for(east - west);
    let mut lon = (west / lon_step).ceil() * lon_step;
    while lon <= east {
        s.push_str(&format!(
            "<line class=\"grid\" x1=\"{0:.1}\" y1=\"0\" x2=\"{0:.1}\" y2=\"{HEIGHT}\"/><text class=\"grid-label\" x=\"{0:.1}\" y=\"{1:.1}\">{2:.3$}°</text>\n",
            x(lon),
            HEIGHT - 4.0,
            lon,
            digits(lon_step)
        ));
        lon += lon_step;
    }
    let lat_step = step_for(north - south);
    let mut lat = (south / lat_step).ceil() * lat_step;
    while lat <= north {
        s.push_str(&format!(
            "<line class=\"grid\" x1=\"0\" y1=\"{0:.1}\" x2=\"{WIDTH}\" y2=\"{0:.1}\"/><text class=\"grid-label\" x=\"4\" y=\"{1:.1}\">{2:.3$}°</text>\n",
            y(lat),
            y(lat) - 3.0,
            lat,
            digits(lat_step)
        ));
        lat += lat_step;
    }
    for p in places {
        let (px, py) = (x(p.longitude_deg), y(p.latitude_deg));
        s.push_str(&format!(
            "<a href=\"{href}\" data-structure=\"{key}\" data-rating=\"{rating}\"><circle class=\"{class}\" cx=\"{px:.1}\" cy=\"{py:.1}\" r=\"7\"><title>{label}: {rating} ({lat:.4}°, {lon:.4}°)</title></circle><text class=\"place\" x=\"{tx:.1}\" y=\"{ty:.1}\">{label}</text></a>\n",
            href = escape(&p.href),
            key = escape(&p.key),
            rating = escape(&p.rating),
            class = dot_class(&p.rating),
            label = escape(&p.label),
            lat = p.latitude_deg,
            lon = p.longitude_deg,
            tx = px + 10.0,
            ty = py + 4.0,
        ));
    }
    s.push_str("</svg>");
    Some(s)
}
