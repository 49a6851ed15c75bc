//! Filter corners chosen per record from its signal-to-noise ratio (issue 34
//! item 1, `conditioning::snr`): a synthetic record whose noise and signal
//! spectra are known, so the frequencies where the ratio crosses the
//! threshold are known in closed form; the bounds; the fallback without a
//! noise window; the history entry and the filter actually applied; and the
//! real CESMD records (`shared_` tests: a digital record with a long
//! pre-event memory, a film record without one).

use quaketwin::conditioning::snr::{self, CornerBounds};
use quaketwin::conditioning::{
    butter_sos, condition_event_each, sosfiltfilt, BandType, ConditioningSettings,
};
use quaketwin::rng::Rng;
use quaketwin::vocab::{Axis, Direction, Event};
use realfft::RealFftPlanner;

use crate::common::{shared_record, x_record};

/// Sampling interval of the synthetic records, s (50 Hz).
const DT: f64 = 0.02;
/// Pre-event noise, strong motion and tail, s.
const NOISE_S: f64 = 1000.0;
const BURST_S: f64 = 1000.0;
const TAIL_S: f64 = 20.0;
/// The signal's amplitude shape G(f): ∝ (f/F1)⁴ below F1, flat to F2, ∝ (F2/f)⁴ above.
const F1: f64 = 1.0;
/// The frequencies where SNR = 3 by construction (see [`Synthetic`]).
const HP_TRUE: f64 = 0.3;
const LP_TRUE: f64 = 14.0;
const THETA: f64 = 3.0;

/// A record of white noise (σ_n) throughout, plus from `onset_s` for
/// `BURST_S` a stationary burst: white noise of σ_w = R·σ_n shaped in the
/// frequency domain by G(f).  Its amplitude density (|X|·Δt/√T) is
/// σ_w·√Δt·G(f) and the noise's σ_n·√Δt, so in the signal window (burst plus
/// noise) SNR(f) = √(R²·G(f)² + 1): it crosses θ = 3 where G(f) = √8/R.
/// R and F2 are set so that happens at [`HP_TRUE`] (on the f⁴ flank) and
/// [`LP_TRUE`] (on the f⁻⁴ flank).
struct Synthetic {
    r: f64,
    f2: f64,
}

impl Synthetic {
    fn new() -> Self {
        let g_cross = (HP_TRUE / F1).powi(4);
        let r = 8f64.sqrt() / g_cross;
        // (F2/LP)⁴ = g_cross.
        let f2 = LP_TRUE * g_cross.powf(0.25);
        Synthetic { r, f2 }
    }
    fn gain(&self, f: f64) -> f64 {
        if f < F1 {
            (f / F1).powi(4)
        } else if f <= self.f2 {
            1.0
        } else {
            (self.f2 / f).powi(4)
        }
    }
    fn record(&self, seed: u64, onset_s: f64, r: f64) -> Vec<f64> {
        let sigma_n = 1e-3;
        let n_total = ((onset_s + BURST_S + TAIL_S) / DT) as usize;
        let n_burst = (BURST_S / DT) as usize;
        let first = (onset_s / DT) as usize;
        let mut rng = Rng::new(seed);
        let mut x = rng.normal_vec(n_total, sigma_n);
        let mut w = rng.normal_vec(n_burst, r * sigma_n);
        let mut planner = RealFftPlanner::<f64>::new();
        let fwd = planner.plan_fft_forward(n_burst);
        let inv = planner.plan_fft_inverse(n_burst);
        let mut spec = fwd.make_output_vec();
        fwd.process(&mut w, &mut spec).unwrap();
        for (k, z) in spec.iter_mut().enumerate() {
            *z *= self.gain(k as f64 / (n_burst as f64 * DT));
        }
        let mut burst = inv.make_output_vec();
        inv.process(&mut spec, &mut burst).unwrap();
        for (i, b) in burst.iter().enumerate() {
            x[first + i] += b / n_burst as f64;
        }
        x
    }
}

fn bounds(hp: [f64; 2], lp: [f64; 2]) -> CornerBounds {
    CornerBounds {
        high_pass: Some(hp),
        low_pass: Some(lp),
    }
}

#[test]
fn the_corners_fall_where_the_ratio_crosses_the_threshold() {
    let s = Synthetic::new();
    // Tolerance: 12 % in frequency.  Konno–Ohmachi smoothing over linear
    // frequency bins raises a steep flank (+13 % for SNR ∝ f⁴: the crossing
    // 3 % low), and the smoothed ratio scatters (a periodogram amplitude by
    // 52 %, averaged over ≈ 100 bins of each 1000-s window).  Measured over
    // seeds 1–20: high-pass 3.2 % low on average (std 2.4 %, worst −9.1 %,
    // seed 2), low-pass 1.2 % high (std 0.3 %).
    const TOL: f64 = 0.12;
    for seed in [1, 2, 3] {
        let x = s.record(seed, NOISE_S, s.r);
        let spectra = snr::fourier_spectra(&x, DT, 4.0).unwrap().unwrap();
        let [n0, n1] = spectra.noise_window_s.expect("a noise window");
        assert_eq!(n0, 0.0);
        // The onset is where the burst starts, within half a second.
        assert!((n1 - NOISE_S).abs() < 0.5, "onset at {n1} s");
        let [s0, s1] = spectra.signal_window_s;
        assert_eq!(s0, n1);
        // 95 % of the energy: the burst dominates, 95 % of its length in.
        assert!(
            (s1 - (NOISE_S + 0.95 * BURST_S)).abs() < 10.0,
            "signal window ends at {s1} s"
        );
        // The ratio in the flat band is √(R²+1) within 20 % (≈ 5 % scatter at 2 Hz).
        let ratio = spectra.snr();
        let at = |f: f64| {
            let i = spectra.frequencies_hz.iter().position(|&c| c >= f).unwrap();
            ratio[i].unwrap()
        };
        let flat = at(2.0);
        let expected = (s.r * s.r + 1.0).sqrt();
        assert!(
            (flat / expected - 1.0).abs() < 0.20,
            "seed {seed}: SNR at 2 Hz {flat}, expected {expected}"
        );
        let choice = snr::choose_corners(&spectra, &bounds([0.1, 0.5], [10.0, 20.0]), THETA);
        assert!(choice.from_snr);
        let hp = choice.high_pass.unwrap();
        let lp = choice.low_pass.unwrap();
        assert!(
            (hp.hz / HP_TRUE - 1.0).abs() < TOL,
            "seed {seed}: high-pass {} Hz, SNR = 3 at {HP_TRUE} Hz ({})",
            hp.hz,
            hp.why
        );
        assert!(
            (lp.hz / LP_TRUE - 1.0).abs() < TOL,
            "seed {seed}: low-pass {} Hz, SNR = 3 at {LP_TRUE} Hz ({})",
            lp.hz,
            lp.why
        );
        assert!(hp.why.contains("rises above 3"), "{}", hp.why);
        assert!(lp.why.contains("falls below 3"), "{}", lp.why);
    }
}

#[test]
fn the_bounds_hold_the_corners() {
    let s = Synthetic::new();
    let x = s.record(7, NOISE_S, s.r);
    let spectra = snr::fourier_spectra(&x, DT, 4.0).unwrap().unwrap();
    // The pipeline's corners above and below the crossings: they stand
    // (never filter less than the pipeline says).
    let c = snr::choose_corners(&spectra, &bounds([0.45, 0.5], [10.0, 12.0]), THETA);
    assert_eq!(c.high_pass.as_ref().unwrap().hz, 0.45);
    assert_eq!(c.low_pass.as_ref().unwrap().hz, 12.0);
    assert!(c.high_pass.unwrap().why.contains("pipeline's corner"));
    // The crossing beyond the highest high-pass / below the lowest low-pass:
    // the bound (a noisy record keeps its first mode).
    let c = snr::choose_corners(&spectra, &bounds([0.1, 0.2], [16.0, 20.0]), THETA);
    let (hp, lp) = (c.high_pass.unwrap(), c.low_pass.unwrap());
    assert_eq!(hp.hz, 0.2);
    assert_eq!(lp.hz, 16.0);
    assert!(hp.why.contains("highest high-pass allowed"), "{}", hp.why);
    assert!(lp.why.contains("lowest low-pass allowed"), "{}", lp.why);
    // Bounds that leave no choice.
    let c = snr::choose_corners(&spectra, &bounds([0.3, 0.3], [14.0, 14.0]), THETA);
    assert_eq!(c.high_pass.unwrap().hz, 0.3);
    assert_eq!(c.low_pass.unwrap().hz, 14.0);
}

#[test]
fn without_a_noise_window_the_pipeline_corners_stand() {
    let s = Synthetic::new();
    let b = bounds([0.1, 0.5], [10.0, 20.0]);
    // One second of record before the shaking: shorter than the 4 s a noise
    // window needs (a triggered record with little pre-event memory).
    let x = s.record(3, 1.0, s.r);
    let spectra = snr::fourier_spectra(&x, DT, 4.0).unwrap().unwrap();
    assert!(spectra.noise_window_s.is_none());
    assert!(spectra.noise.is_empty() && spectra.snr().iter().all(Option::is_none));
    let why = spectra.no_noise.clone().unwrap();
    assert!(why.contains("shorter than the 4 s"), "{why}");
    let c = snr::choose_corners(&spectra, &b, THETA);
    assert!(!c.from_snr);
    assert_eq!(c.high_pass.as_ref().unwrap().hz, 0.1);
    assert_eq!(c.low_pass.as_ref().unwrap().hz, 20.0);
    assert!(c.high_pass.unwrap().why.contains("no noise window"));
    // A loud "pre-event" (the shaking only 3 times the noise: a record that
    // starts on its P wave looks like this): not a noise window.
    let x = s.record(4, NOISE_S, 3.0);
    let spectra = snr::fourier_spectra(&x, DT, 4.0).unwrap().unwrap();
    assert!(
        spectra.noise_window_s.is_none(),
        "{:?}",
        spectra.noise_window_s
    );
    assert!(spectra.no_noise.unwrap().contains("not quiet"));
    // A silent (exactly zero) pre-event: a noise window of zero noise, the
    // ratio unbounded, the pipeline's corners.
    let mut x = s.record(5, NOISE_S, s.r);
    for v in x.iter_mut().take((NOISE_S / DT) as usize) {
        *v = 0.0;
    }
    let spectra = snr::fourier_spectra(&x, DT, 4.0).unwrap().unwrap();
    assert!(spectra.noise_window_s.is_some());
    let c = snr::choose_corners(&spectra, &b, THETA);
    assert!(c.from_snr);
    assert_eq!(c.high_pass.unwrap().hz, 0.1);
    assert_eq!(c.low_pass.unwrap().hz, 20.0);
}

fn snr_settings(extra: &str) -> ConditioningSettings {
    let text = format!(
        "steps = [{{ step = \"filter\", order = 4, band = \"bandpass\", corners_hz = [0.1, 20.0], corners_from = \"snr\"{extra} }}]"
    );
    let settings: ConditioningSettings = toml::from_str(&text).unwrap();
    settings.validate().unwrap();
    settings
}

fn corners_of(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

#[test]
fn the_filter_applies_the_event_corners_and_the_history_says_why() {
    let s = Synthetic::new();
    let quiet = s.record(11, NOISE_S, s.r);
    let quiet2 = s.record(13, NOISE_S, s.r);
    let short = s.record(12, 1.0, s.r);
    let mut event = Event {
        name: "snr".into(),
        records: vec![
            x_record("A1", 0, 1.0 / DT, "a.csv", quiet.clone()),
            x_record("A2", 1, 1.0 / DT, "a.csv", short.clone()),
            x_record("A3", 2, 1.0 / DT, "a.csv", quiet2.clone()),
        ],
        ..Default::default()
    };
    let settings = snr_settings("");
    let out = condition_event_each(&mut event, &settings, None, &|_, _| Ok(())).unwrap();
    assert_eq!(out.fourier.len(), 3);
    let step = event
        .history
        .steps
        .iter()
        .find(|s| s.step == "filter")
        .expect("a filter step in the history");
    assert_eq!(step.params["corners_from"], "snr");
    assert_eq!(step.params["snr_min"], 3.0);
    assert_eq!(
        step.params["bounds_hz"]["high_pass"],
        serde_json::json!([0.1, 0.5])
    );
    let per = &step.params["per_channel"];
    // Each record's own corners: from its ratio (A1, A3), the pipeline's (A2).
    let own1 = corners_of(&per["A1"]["own_corners_hz"]);
    let own3 = corners_of(&per["A3"]["own_corners_hz"]);
    assert_eq!(corners_of(&per["A2"]["own_corners_hz"]), [0.1, 20.0]);
    for own in [&own1, &own3] {
        assert!((own[0] / HP_TRUE - 1.0).abs() < 0.12, "{own:?}");
        assert!((own[1] / LP_TRUE - 1.0).abs() < 0.12, "{own:?}");
    }
    // Applied to all three alike: the highest high-pass, the lowest low-pass
    // of the two records with a noise window (two of three: a majority).
    let common = [own1[0].max(own3[0]), own1[1].min(own3[1])];
    for id in ["A1", "A2", "A3"] {
        assert_eq!(corners_of(&per[id]["corners_hz"]), common, "{id}");
        assert_eq!(per[id]["from"], "snr", "{id}");
        let why = per[id]["high_pass"].as_str().unwrap();
        assert!(why.contains("filtered alike"), "{id}: {why}");
    }
    assert!(per["A1"]["noise_window_s"].is_array());
    assert!(per["A2"]["noise_window_s"].is_null());
    // Each record filtered with the corners the history states.
    for (id, raw) in [("A1", &quiet), ("A2", &short), ("A3", &quiet2)] {
        let sos = butter_sos(4, BandType::Bandpass, &common, 1.0 / DT).unwrap();
        let expected = sosfiltfilt(&sos, raw).unwrap();
        let got = event.record(id).unwrap().samples.get().unwrap();
        assert_eq!(got.as_ref(), expected.as_slice(), "{id}");
    }
}

#[test]
fn an_event_without_a_majority_of_noise_windows_keeps_the_pipeline_corners() {
    use quaketwin::conditioning::snr::{common_corners, Corner, CornerChoice};
    let b = bounds([0.1, 0.5], [10.0, 20.0]);
    let snr = |hp: f64, lp: f64| CornerChoice {
        high_pass: Some(Corner {
            hz: hp,
            why: "where the signal-to-noise ratio rises above 3".into(),
        }),
        low_pass: Some(Corner {
            hz: lp,
            why: "where the signal-to-noise ratio falls below 3".into(),
        }),
        from_snr: true,
    };
    let stated = CornerChoice::stated(&b, "the pipeline's corner: no noise window");
    let (a, c, d) = (snr(0.2, 15.0), snr(0.3, 18.0), stated.clone());
    let common = common_corners(&[("a", &a), ("c", &c), ("d", &d)], &b, "horizontal");
    for x in &common {
        assert_eq!(x.high_pass.as_ref().unwrap().hz, 0.3);
        assert_eq!(x.low_pass.as_ref().unwrap().hz, 15.0);
        assert!(x.from_snr);
    }
    assert!(common[0]
        .high_pass
        .as_ref()
        .unwrap()
        .why
        .contains("on c, the highest"));
    assert!(common[0]
        .low_pass
        .as_ref()
        .unwrap()
        .why
        .contains("on a, the lowest"));
    // One of three with a noise window (a film recorder whose P wave passed
    // for noise on one channel): the pipeline's corners for all.
    let (e, f) = (stated.clone(), stated.clone());
    let common = common_corners(&[("a", &a), ("e", &e), ("f", &f)], &b, "horizontal");
    for x in &common {
        assert!(!x.from_snr);
        assert_eq!(x.high_pass.as_ref().unwrap().hz, 0.1);
        assert_eq!(x.low_pass.as_ref().unwrap().hz, 20.0);
        assert!(x
            .high_pass
            .as_ref()
            .unwrap()
            .why
            .contains("only 1 of the event's 3"));
    }
    // A record alone keeps its own.
    assert_eq!(
        common_corners(&[("a", &a)], &b, "vertical"),
        vec![a.clone()]
    );
}

#[test]
fn snr_filter_settings_are_checked() {
    let bad = |text: &str| -> String {
        match toml::from_str::<ConditioningSettings>(text) {
            Err(e) => e.to_string(),
            Ok(s) => s.validate().unwrap_err().to_string(),
        }
    };
    let one = |extra: &str| {
        format!("steps = [{{ step = \"filter\", order = 4, band = \"bandpass\", corners_hz = [0.1, 20.0], corners_from = \"snr\"{extra} }}]")
    };
    assert!(bad(&one(", snr_min = 0.5")).contains("snr_min"));
    assert!(bad(&one(", noise_min_s = -1.0")).contains("noise_min_s"));
    assert!(bad(&one(", high_pass_max_hz = 12.0")).contains("below the lowest low-pass"));
    let loud = "steps = [{ step = \"filter\", order = 4, band = \"bandpass\", corners_hz = [0.1, 20.0], corners_from = \"loud\" }]";
    assert!(bad(loud).contains("loud"), "{}", bad(loud));
    let stop = "steps = [{ step = \"filter\", order = 4, band = \"bandstop\", corners_hz = [1.0, 2.0], corners_from = \"snr\" }]";
    assert!(bad(stop).contains("bandstop"));
    let two = "steps = [{ step = \"filter\", order = 2, band = \"highpass\", corners_hz = [0.1], corners_from = \"snr\" }, { step = \"filter\", order = 2, band = \"lowpass\", corners_hz = [20.0], corners_from = \"snr\" }]";
    assert!(bad(two).contains("at most one"));
    // A high-pass alone: only a high-pass corner is chosen.
    let hp: ConditioningSettings = toml::from_str(
        "steps = [{ step = \"filter\", order = 2, band = \"highpass\", corners_hz = [0.1], corners_from = \"snr\" }]",
    )
    .unwrap();
    hp.validate().unwrap();
    let b = hp.snr_filter().unwrap().corner_bounds();
    assert_eq!(b.high_pass, Some([0.1, 0.5]));
    assert_eq!(b.low_pass, None);
}

/// The corners of every acceleration channel of a real event conditioned
/// with the SNR filter of the shipped pipelines.
fn real_corners(rel: &str) -> Vec<(String, bool, f64, f64, String)> {
    let zip = shared_record(rel);
    let mut event = quaketwin::event_folder::load(&zip).unwrap().event;
    let settings = snr_settings("");
    let out = condition_event_each(&mut event, &settings, None, &|_, _| Ok(())).unwrap();
    assert!(!out.fourier.is_empty(), "{rel}: no channel analysed");
    out.fourier
        .iter()
        .map(|f| {
            let c = &f.choice;
            let (hp, lp) = (c.high_pass.as_ref().unwrap(), c.low_pass.as_ref().unwrap());
            // Inside the bounds, a pass band left.
            assert!(
                (0.1..=0.5).contains(&hp.hz),
                "{rel} {}: {hp:?}",
                f.channel_id
            );
            assert!(
                (10.0..=20.0).contains(&lp.hz),
                "{rel} {}: {lp:?}",
                f.channel_id
            );
            (
                f.channel_id.clone(),
                c.from_snr,
                hp.hz,
                lp.hz,
                format!("{}; {}", hp.why, lp.why),
            )
        })
        .collect()
}

#[test]
fn shared_digital_record_with_pre_event_memory_gets_snr_corners() {
    // Ridgecrest Hwy 395/Brown Road bridge, 4 July 2019 (M6.4 foreshock),
    // 9 channels with ≈ 14 s of pre-event memory.  The network processed
    // these records (V2) with a 0.10 Hz high-pass: a corner chosen from the
    // same noise agrees within a factor of two, and the pass band reaches
    // the pipeline's 20 Hz (SNR ≥ 3 up to there on this strong record).
    let corners = real_corners("cesmd-bridges-corpus/ridgecrest-ce33742/ci38443183_ce33742p.zip");
    assert_eq!(corners.len(), 9);
    for (id, from_snr, hp, lp, why) in &corners {
        assert!(*from_snr, "{id}: {why}");
        assert!(*hp <= 0.2, "{id}: high-pass {hp} Hz ({why})");
        assert!(*lp >= 15.0, "{id}: low-pass {lp} Hz ({why})");
    }
    // The six horizontal records filtered alike (three vertical ones among the nine).
    let mut pairs: Vec<(f64, f64)> = corners.iter().map(|c| (c.2, c.3)).collect();
    pairs.sort_by(|a, b| a.partial_cmp(b).unwrap());
    pairs.dedup();
    assert!(pairs.len() <= 2, "{pairs:?}");
}

#[test]
fn shared_film_record_without_pre_event_memory_keeps_the_pipeline_corners() {
    // Painter Street overpass, Rio Dell 1982: an analogue (film) recorder
    // that starts on the P wave: no noise window, the pipeline's corners.
    let corners = real_corners("cesmd-bridges-corpus/painter-st-ce89324/riodell82_ce89324p.zip");
    for (id, from_snr, hp, lp, why) in &corners {
        assert!(!from_snr, "{id}: {why}");
        assert_eq!((*hp, *lp), (0.1, 20.0), "{id}");
        assert!(why.contains("no noise window"), "{id}: {why}");
    }
}

#[test]
fn fourier_table_and_report_section() {
    let s = Synthetic::new();
    let mut event = Event {
        name: "snr".into(),
        records: vec![
            x_record("CH10", 1, 1.0 / DT, "a.csv", s.record(21, NOISE_S, s.r)),
            {
                // A vertical record (its own group) without a noise window.
                let mut r = x_record("CH2", 0, 1.0 / DT, "a.csv", s.record(22, 1.0, s.r));
                r.channel.direction = Some(Direction::Axis(Axis::Z));
                r
            },
        ],
        ..Default::default()
    };
    let out = condition_event_each(&mut event, &snr_settings(""), None, &|_, _| Ok(())).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fourier/fourier.parquet");
    quaketwin::sinks::fourier_tables::write_fourier(&path, &event, &out.fourier).unwrap();
    let ids = crate::common::column_str(&path, "channel_id");
    let freq = crate::common::column_f64(&path, "frequency_hz");
    let snr_col = crate::common::column_f64(&path, "snr");
    let hp = crate::common::column_f64(&path, "high_pass_hz");
    let from = crate::common::column_str(&path, "corners_from");
    let n10 = ids.iter().filter(|i| *i == "CH10").count();
    assert!(n10 > 100, "{n10} rows");
    for i in 0..ids.len() {
        if ids[i] == "CH2" {
            assert!(snr_col[i].is_nan(), "no noise window: no ratio");
            assert_eq!(hp[i], 0.1);
            assert_eq!(from[i], "stated");
        } else {
            assert_eq!(from[i], "snr");
            assert!(freq[i] > 0.0);
        }
    }
    let html = quaketwin::report::render_report(dir.path(), &Default::default()).unwrap();
    let start = html.find("id=\"fourier\"").expect("the section");
    let section = &html[start..];
    let section = &section[..section.find("</section>").unwrap()];
    // Natural channel order: CH2 before CH10; a chart each, in words.
    let (a, b) = (
        section.find("Channel CH2").unwrap(),
        section.find("Channel CH10").unwrap(),
    );
    assert!(a < b);
    assert_eq!(section.matches("<svg").count(), 2);
    assert!(section.contains("chosen from the signal-to-noise ratio"));
    assert!(section.contains("the pipeline&#39;s corners"));
    assert!(!section.contains("fourier/fourier.parquet") && !section.contains("noise_fas"));
}

#[test]
fn a_long_pre_event_gives_a_noise_window_of_its_last_30_minutes() {
    let s = Synthetic::new();
    let x = s.record(31, 2400.0, s.r);
    let spectra = snr::fourier_spectra(&x, DT, 4.0).unwrap().unwrap();
    let [n0, n1] = spectra.noise_window_s.unwrap();
    assert!((n1 - 2400.0).abs() < 0.5, "onset at {n1} s");
    assert!((n1 - n0 - snr::MAX_SIGNAL_S).abs() < 2.0 * DT, "{n0}–{n1}");
}
