// TEMPORARY exploration (deleted before hand-off).
use quaketwin::readers::{self, ReadOptions};
use quaketwin::vocab::SourceRef;
use std::io::Read;

const R: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/records");

fn src(f: &str, m: Option<&str>, fmt: &str) -> SourceRef {
    SourceRef { file: f.into(), member: m.map(String::from), column: None, format: fmt.into() }
}
fn show(name: &str, c: &readers::FileContents) {
    println!("== {name} event={:?}", c.event);
    for r in &c.records {
        let ch = &r.channel;
        let pk = r.samples.iter().fold(0.0f64, |a, &v| if v.abs() > a.abs() { v } else { a });
        println!("  id={} net={:?} sta={:?} loc={:?} cha={:?} lt={:?} dir={:?} u={} fs={} start={:?} n={} first={:?} last={:?} peak={} qa={:?} inf={:?} miss={:?} elev={:?}",
            ch.id, ch.network, ch.station, ch.location_code, ch.channel_code, ch.location_text, ch.direction, ch.units, ch.sampling_rate_hz,
            ch.start_ns.map(quaketwin::vocab::format_epoch_ns), r.samples.len(), r.samples.first(), r.samples.last(), pk, ch.qa, ch.inferred, ch.missing, ch.elevation_m);
    }
    for s in &c.spectra { println!("  spec {} d={} n={} p0={} psa0={} last={:?}", s.channel_id, s.damping, s.periods_s.len(), s.periods_s[0], s.psa[0], s.psa.last()); }
}
fn one(path: &str, fmt: readers::Format) {
    let b = std::fs::read(format!("{R}/{path}")).unwrap();
    match readers::read(fmt, &b, &src(path, None, fmt.name()), &ReadOptions::default()) {
        Ok(c) => show(path, &c),
        Err(e) => println!("ERR {path}: {e}"),
    }
}
fn zip_all(path: &str) {
    let b = std::fs::read(format!("{R}/{path}")).unwrap();
    walk(path, &b, "");
}
fn walk(path: &str, b: &[u8], prefix: &str) {
    let mut z = zip::ZipArchive::new(std::io::Cursor::new(b.to_vec())).unwrap();
    for i in 0..z.len() {
        let mut f = z.by_index(i).unwrap();
        let name = f.name().unwrap().to_string();
        let mut v = Vec::new();
        f.read_to_end(&mut v).unwrap();
        let member = format!("{prefix}{name}");
        if name.ends_with(".zip") { walk(path, &v, &format!("{member}:")); continue; }
        let fmt = readers::sniff(&name, &v);
        match readers::read(readers::Format::Dmg, &v, &src(path, Some(&member), "dmg"), &ReadOptions::default()) {
            Ok(c) => { println!("sniff={fmt:?}"); show(&member, &c) },
            Err(e) => println!("ERR {member}: {e}"),
        }
    }
}
#[test]
fn dump() {
    use readers::Format::*;
    for f in ["peer-at2-records/TAK000.AT2","peer-at2-records/RSN763_LOMAP_GIL067.AT2","peer-at2-records/RSN763_LOMAP_GIL337.AT2","peer-at2-records/elCentro.AT2"] { one(f, At2); }
    for f in ["a","b","c"] { one(&format!("usgs-gmprocess-format-samples/smc/0111{f}.smc"), Smc); }
    one("usgs-gmprocess-format-samples/geonet/20180212_211557_WPWS_20.V2A", GeoNet);
    one("usgs-gmprocess-format-samples/cosmos/NP8040-n.1000hyfh.HNE.01.V0c", Cosmos);
    one("usgs-gmprocess-format-samples/cosmos/us1000hyfh_akbmrp_AKBMR--n.1000hyfh.BNZ.--.acc.V2c", Cosmos);
    one("usgs-gmprocess-format-samples/dmg/CE58667.V2", Dmg);
    one("usgs-gmprocess-format-samples/dmg/ce36456p_CE36456.V2", Dmg);
    zip_all("csmip-ce01336-meloland-overpass/imperialvalley79_ce01336p.zip");
    zip_all("csmip-ce89324-painterst-overpass/petrolia_25apr1992_ce89324p.zip");
    zip_all("csmip-ce89324-painterst-overpass/nc73943821_ce89324p.zip");
    zip_all("csmip-ce89324-painterst-overpass/nested_original/petrolia_25apr1992_ce89324p.zip");
}
