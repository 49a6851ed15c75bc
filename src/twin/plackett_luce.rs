//! Plackett–Luce rank aggregation (thesis §3.2.1, METHODS.md §3).
//!
//! Voters k = 1..K give candidates i = 1..I scores w_k,i (Eq. 4). The probability of a
//! ranking C (best first) is f = Π_k Π_r w_k,C(r) / Σ_{s≥r} w_k,C(s) (Eq. 1–2); the selected
//! ranking maximises f.
//!
//! Search: exhaustive over the I! permutations in lexicographic order while I ≤ 8 (ties: the
//! first maximum, a later permutation must beat it by more than 1e-12 relative in log f).
//! Beyond 8 candidates we use an exact dynamic programme: Σ_r ln w_k,C(r) does not depend on
//! the order, so ln f = const − Σ_r Σ_k ln W_k(S_r) where S_r is the set of candidates from
//! position r on and W_k(S) = Σ_{s∈S} w_k,s. The chain S_1 ⊃ S_2 ⊃ … ⊃ S_I is a shortest path
//! over subsets (O(2^I · I)), which is exact; it is used up to 20 candidates (ties: at each
//! position the lowest candidate index among the optima). Above 20 candidates we start from
//! the order by Σ_k ln w_k,i and improve it by adjacent swaps until no swap helps (a local
//! optimum, stated as such in `RankingMethod::LocalSearch`).

/// Scores of Eq. 4 from the normalised scatters β (Eq. 3): `scatters[k][i]` for voter k and
/// candidate i. w*_k,i = exp(−(β_k,i/σ_k)²) with σ_k the population standard deviation of
/// β_k,· over the candidates; w_k,i = w*_k,i / Σ_i w*_k,i. A voter with σ_k = 0 (all
/// candidates equal) or non-finite scatters gives equal weights 1/I.
pub fn scores(scatters: &[Vec<f64>]) -> Vec<Vec<f64>> {
    scatters
        .iter()
        .map(|beta| {
            let n = beta.len();
            if n == 0 {
                return Vec::new();
            }
            let equal = vec![1.0 / n as f64; n];
            if beta.iter().any(|b| !b.is_finite()) {
                // A failed candidate gets a negligible weight (1e-300, so logarithms stay
                // finite and it ranks last); the others get Eq. 4 among themselves.
                let finite: Vec<usize> = (0..n).filter(|&i| beta[i].is_finite()).collect();
                if finite.is_empty() {
                    return equal;
                }
                let sub: Vec<f64> = finite.iter().map(|&i| beta[i]).collect();
                let w = scores(&[sub]).pop().unwrap_or_default();
                let mut out = vec![1e-300; n];
                for (j, &i) in finite.iter().enumerate() {
                    out[i] = w[j];
                }
                return out;
            }
            let mean = beta.iter().sum::<f64>() / n as f64;
            let sigma =
                (beta.iter().map(|b| (b - mean) * (b - mean)).sum::<f64>() / n as f64).sqrt();
            if !(sigma > 0.0) {
                return equal;
            }
            let raw: Vec<f64> = beta.iter().map(|b| (-(b / sigma).powi(2)).exp()).collect();
            let total: f64 = raw.iter().sum();
            if !(total > 0.0) {
                return equal;
            }
            raw.iter().map(|w| w / total).collect()
        })
        .collect()
}

/// ln f_p of Eq. 2 for `ranking` (candidate indices, best first); weights[k][i].
pub fn log_probability(weights: &[Vec<f64>], ranking: &[usize]) -> f64 {
    let mut lp = 0.0;
    for w in weights {
        // Suffix sums accumulated from the back (no cancellation for tiny weights).
        let mut tail = 0.0;
        for &i in ranking.iter().rev() {
            tail += w[i];
            lp += w[i].ln() - tail.ln();
        }
    }
    lp
}

/// f_p of Eq. 2 (may underflow for many voters; use `log_probability` to compare).
pub fn probability(weights: &[Vec<f64>], ranking: &[usize]) -> f64 {
    log_probability(weights, ranking).exp()
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RankingMethod {
    Exhaustive,
    DynamicProgramme,
    LocalSearch,
}

/// The selected ranking.
#[derive(Debug, Clone, PartialEq)]
pub struct Ranking {
    /// Candidate indices, best first.
    pub order: Vec<usize>,
    pub log_probability: f64,
    pub method: RankingMethod,
}

impl Ranking {
    /// 1-based position of each candidate.
    pub fn positions(&self) -> Vec<usize> {
        let mut pos = vec![0; self.order.len()];
        for (r, &i) in self.order.iter().enumerate() {
            pos[i] = r + 1;
        }
        pos
    }
}

/// Largest candidate count ranked exhaustively.
pub const EXHAUSTIVE_LIMIT: usize = 8;
/// Largest candidate count ranked by the exact subset dynamic programme.
pub const DP_LIMIT: usize = 20;

/// Next permutation in lexicographic order; false after the last.
fn next_permutation(p: &mut [usize]) -> bool {
    let n = p.len();
    if n < 2 {
        return false;
    }
    let mut i = n - 1;
    while i > 0 && p[i - 1] >= p[i] {
        i -= 1;
    }
    if i == 0 {
        return false;
    }
    let mut j = n - 1;
    while p[j] <= p[i - 1] {
        j -= 1;
    }
    p.swap(i - 1, j);
    p[i..].reverse();
    true
}

/// The maximum-likelihood ranking of Eq. 2 (see the module notes for the search).
pub fn best_ranking(weights: &[Vec<f64>]) -> Ranking {
    let n = weights.first().map(|w| w.len()).unwrap_or(0);
    if n <= EXHAUSTIVE_LIMIT {
        best_ranking_exhaustive(weights)
    } else if n <= DP_LIMIT {
        best_ranking_dp(weights)
    } else {
        best_ranking_local(weights)
    }
}

pub fn best_ranking_exhaustive(weights: &[Vec<f64>]) -> Ranking {
    let n = weights.first().map(|w| w.len()).unwrap_or(0);
    let mut perm: Vec<usize> = (0..n).collect();
    let mut best = perm.clone();
    let mut best_lp = log_probability(weights, &perm);
    while next_permutation(&mut perm) {
        let lp = log_probability(weights, &perm);
        if lp > best_lp + 1e-12 * best_lp.abs().max(1.0) || (best_lp.is_nan() && !lp.is_nan()) {
            best_lp = lp;
            best.clone_from(&perm);
        }
    }
    Ranking {
        order: best,
        log_probability: best_lp,
        method: RankingMethod::Exhaustive,
    }
}

pub fn best_ranking_dp(weights: &[Vec<f64>]) -> Ranking {
    let n = weights.first().map(|w| w.len()).unwrap_or(0);
    let full = (1usize << n) - 1;
    // cost(S) = Σ_k ln W_k(S); best[S] = cost(S) + min_{i∈S} best[S∖{i}].
    let mut best = vec![0.0f64; full + 1];
    let mut sums = vec![0.0f64; weights.len()];
    for set in 1..=full {
        sums.iter_mut().for_each(|s| *s = 0.0);
        for i in 0..n {
            if set & (1 << i) != 0 {
                for (k, w) in weights.iter().enumerate() {
                    sums[k] += w[i];
                }
            }
        }
        let cost: f64 = sums.iter().map(|s| s.ln()).sum();
        let mut m = f64::INFINITY;
        for i in 0..n {
            if set & (1 << i) != 0 {
                m = m.min(best[set & !(1 << i)]);
            }
        }
        best[set] = cost + m;
    }
    let mut order = Vec::with_capacity(n);
    let mut set = full;
    while set != 0 {
        let target = (0..n)
            .filter(|i| set & (1 << i) != 0)
            .map(|i| best[set & !(1 << i)])
            .fold(f64::INFINITY, f64::min);
        let tol = 1e-12 * target.abs().max(1.0);
        let pick = (0..n)
            .find(|&i| set & (1 << i) != 0 && best[set & !(1 << i)] <= target + tol)
            .unwrap_or(0);
        order.push(pick);
        set &= !(1 << pick);
    }
    let lp = log_probability(weights, &order);
    Ranking {
        order,
        log_probability: lp,
        method: RankingMethod::DynamicProgramme,
    }
}

pub fn best_ranking_local(weights: &[Vec<f64>]) -> Ranking {
    let n = weights.first().map(|w| w.len()).unwrap_or(0);
    let strength: Vec<f64> = (0..n)
        .map(|i| weights.iter().map(|w| w[i].ln()).sum())
        .collect();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| strength[b].total_cmp(&strength[a]).then(a.cmp(&b)));
    let mut lp = log_probability(weights, &order);
    loop {
        let mut improved = false;
        for r in 0..n.saturating_sub(1) {
            order.swap(r, r + 1);
            let trial = log_probability(weights, &order);
            if trial > lp + 1e-12 * lp.abs().max(1.0) {
                lp = trial;
                improved = true;
            } else {
                order.swap(r, r + 1);
            }
        }
        if !improved {
            break;
        }
    }
    Ranking {
        order,
        log_probability: lp,
        method: RankingMethod::LocalSearch,
    }
}
