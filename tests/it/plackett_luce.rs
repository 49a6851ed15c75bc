//! Plackett–Luce rank aggregation (Eq. 1–2) and scores (Eq. 4) against hand-computed values.

use quaketwin::rng::Rng;
use quaketwin::twin::plackett_luce::{
    best_ranking, best_ranking_dp, best_ranking_exhaustive, best_ranking_local, log_probability,
    probability, scores, RankingMethod,
};

/// One voter, weights (0.5, 0.3, 0.2): P(0,1,2) = 0.5/1 · 0.3/0.5 · 0.2/0.2 = 0.3 and
/// P(2,1,0) = 0.2/1 · 0.3/0.8 · 0.5/0.5 = 0.075; the best ranking sorts by weight.
#[test]
fn one_voter_probabilities_and_best_ranking() {
    let w = vec![vec![0.5, 0.3, 0.2]];
    assert!((probability(&w, &[0, 1, 2]) - 0.3).abs() < 1e-15);
    assert!((probability(&w, &[2, 1, 0]) - 0.075).abs() < 1e-15);
    assert!((probability(&w, &[1, 0, 2]) - 0.3 * 0.5 / 0.7).abs() < 1e-15);
    // Probabilities of all 6 rankings sum to 1.
    let all = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let total: f64 = all.iter().map(|r| probability(&w, r)).sum();
    assert!((total - 1.0).abs() < 1e-14);
    let w = vec![vec![0.1, 0.4, 0.15, 0.35]];
    let best = best_ranking(&w);
    assert_eq!(best.order, vec![1, 3, 2, 0]);
    assert_eq!(best.method, RankingMethod::Exhaustive);
    assert_eq!(best.positions(), vec![4, 1, 3, 2]);
}

/// Two voters that disagree: voter 1 (0.6, 0.3, 0.1) prefers (0,1,2) with 0.6·0.3/0.4 = 0.45;
/// voter 2 (0.2, 0.3, 0.5) prefers (2,1,0) with 0.5·0.3/0.5 = 0.3. Joint (Eq. 2):
/// (0,1,2): 0.45 · (0.2·0.3/0.8 = 0.075) = 0.03375 — the maximum;
/// (1,0,2): (0.3·0.6/0.7) · (0.3·0.2/0.7) = 0.0220408…;
/// (0,2,1): 0.15 · 0.125 = 0.01875; (2,0,1): (0.1·0.6/0.9) · (0.5·0.2/0.5) = 0.013333…;
/// (2,1,0): (0.1·0.3/0.9) · 0.3 = 0.01; (1,2,0): (0.3·0.1/0.7) · (0.3·0.5/0.7) = 0.0091837….
#[test]
fn two_disagreeing_voters() {
    let w = vec![vec![0.6, 0.3, 0.1], vec![0.2, 0.3, 0.5]];
    let expect = [
        ([0, 1, 2], 0.03375),
        ([1, 0, 2], 0.3 * 0.6 / 0.7 * (0.3 * 0.2 / 0.7)),
        ([0, 2, 1], 0.01875),
        ([2, 0, 1], 0.1 * 0.6 / 0.9 * 0.2),
        ([2, 1, 0], 0.01),
        ([1, 2, 0], 0.3 * 0.1 / 0.7 * (0.3 * 0.5 / 0.7)),
    ];
    for (r, p) in expect {
        assert!(
            (probability(&w, &r) - p).abs() < 1e-15,
            "{r:?}: {} vs {p}",
            probability(&w, &r)
        );
    }
    let best = best_ranking(&w);
    assert_eq!(best.order, vec![0, 1, 2]);
    assert!((best.log_probability - 0.03375f64.ln()).abs() < 1e-12);
    // Each voter alone picks its own order.
    assert_eq!(best_ranking(&w[..1]).order, vec![0, 1, 2]);
    assert_eq!(best_ranking(&w[1..]).order, vec![2, 1, 0]);
}

/// Symmetric disagreement ties (0,1,2) and (2,1,0) at 0.45 · 0.0333… = 0.015: the first
/// maximum in lexicographic order wins.
#[test]
fn ties_go_to_the_first_ranking_in_lexicographic_order() {
    let w = vec![vec![0.6, 0.3, 0.1], vec![0.1, 0.3, 0.6]];
    assert!((probability(&w, &[0, 1, 2]) - 0.015).abs() < 1e-15);
    assert!((probability(&w, &[2, 1, 0]) - 0.015).abs() < 1e-15);
    assert_eq!(best_ranking(&w).order, vec![0, 1, 2]);
    assert_eq!(best_ranking_dp(&w).order, vec![0, 1, 2]);
}

/// Eq. 4 by hand: β = (0.1, 0.2, 0.3) → mean 0.2, population σ = √(0.02/3);
/// w* = exp(−(β/σ)²) = (e^−1.5, e^−6, e^−13.5), normalised. σ = 0 → equal weights.
#[test]
fn scores_follow_eq_4() {
    let w = scores(&[vec![0.1, 0.2, 0.3], vec![0.25, 0.25, 0.25]]);
    let raw = [(-1.5f64).exp(), (-6.0f64).exp(), (-13.5f64).exp()];
    let total: f64 = raw.iter().sum();
    for i in 0..3 {
        assert!(
            (w[0][i] - raw[i] / total).abs() < 1e-12,
            "{} vs {}",
            w[0][i],
            raw[i] / total
        );
        assert!((w[1][i] - 1.0 / 3.0).abs() < 1e-15);
    }
    // A candidate whose model failed (β = ∞) gets a negligible weight and ranks last.
    let w = scores(&[vec![0.1, f64::INFINITY, 0.3]]);
    assert!(w[0][1] < 1e-200);
    assert_eq!(best_ranking(&w).order, vec![0, 2, 1]);
}

fn random_weights(rng: &mut Rng, voters: usize, candidates: usize) -> Vec<Vec<f64>> {
    (0..voters)
        .map(|_| {
            let raw: Vec<f64> = (0..candidates).map(|_| rng.uniform_in(0.01, 1.0)).collect();
            let s: f64 = raw.iter().sum();
            raw.iter().map(|v| v / s).collect()
        })
        .collect()
}

/// The subset dynamic programme used beyond 8 candidates is exact: it agrees with the
/// exhaustive search wherever both run.
#[test]
fn dynamic_programme_matches_exhaustive_search() {
    let mut rng = Rng::new(11);
    for n in 2..=7 {
        for _ in 0..20 {
            let w = random_weights(&mut rng, 4, n);
            let a = best_ranking_exhaustive(&w);
            let b = best_ranking_dp(&w);
            assert!((a.log_probability - b.log_probability).abs() < 1e-10);
            assert_eq!(a.order, b.order);
        }
    }
    // Beyond the exhaustive limit the DP is used.
    let w = random_weights(&mut rng, 3, 10);
    let r = best_ranking(&w);
    assert_eq!(r.method, RankingMethod::DynamicProgramme);
    // No single adjacent swap improves the optimum.
    for i in 0..9 {
        let mut o = r.order.clone();
        o.swap(i, i + 1);
        assert!(log_probability(&w, &o) <= r.log_probability + 1e-12);
    }
}

/// Beyond 20 candidates: the local search returns a permutation at least as likely as its
/// start (candidates ordered by Σ_k ln w_k,i) and no adjacent swap improves it.
#[test]
fn local_search_beyond_twenty_candidates() {
    let mut rng = Rng::new(5);
    let w = random_weights(&mut rng, 3, 25);
    let r = best_ranking(&w);
    assert_eq!(r.method, RankingMethod::LocalSearch);
    let mut sorted: Vec<usize> = r.order.clone();
    sorted.sort();
    assert_eq!(sorted, (0..25).collect::<Vec<_>>());
    let strength: Vec<f64> = (0..25).map(|i| w.iter().map(|v| v[i].ln()).sum()).collect();
    let mut start: Vec<usize> = (0..25).collect();
    start.sort_by(|&a, &b| strength[b].total_cmp(&strength[a]));
    assert!(r.log_probability >= log_probability(&w, &start) - 1e-12);
    assert_eq!(best_ranking_local(&w).order, r.order);
}
