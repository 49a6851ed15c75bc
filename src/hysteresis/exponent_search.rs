//! The search over the Bouc-Wen exponent N for one DoF (METHODS.md §4): every
//! trial N gives one bounded least-squares problem per STFT frame (Eq. 19–20
//! under Eq. 47) from cached per-frame products; J(N) (Eq. 31) is searched on a
//! coarse grid (it is not convex in N), then the best local minima are refined
//! by successively finer grids (steps ÷5) down to the resolution.  Every trial N
//! is cached; trial batches run in parallel (rayon).

use std::collections::BTreeMap;

use rayon::prelude::*;

use crate::error::{Error, Result};

use super::basis::DofProblem;
use super::settings::IdentifySettings;
use super::solve::bounded_lsq_gram;
use super::stft::{frame_products, FrameRepresentation, FrameTransformer};

/// Per-frame cumulative solution at one trial N.
#[derive(Debug, Clone)]
pub(super) struct FrameFit {
    pub(super) cost: f64,
    pub(super) p: Vec<f64>,
    /// Cumulative H_ss + H_tt (weight of the hysteretic columns so far).
    pub(super) nonlinear_weight: f64,
}

#[derive(Debug, Clone)]
pub(super) struct Evaluation {
    pub(super) frames: Vec<FrameFit>,
}

impl Evaluation {
    pub(super) fn last(&self) -> &FrameFit {
        // An evaluation always has at least one frame (layouts have ≥ 1 frame).
        &self.frames[self.frames.len() - 1]
    }
}

/// Evaluates trial exponents for one DoF with cached per-frame products of
/// the N-independent columns.
pub(super) struct DofEngine<'a> {
    problem: &'a DofProblem,
    transformer: &'a FrameTransformer,
    frames: usize,
    /// Frame representations of [fixed…, target].
    pub(super) fixed_reps: Vec<FrameRepresentation>,
    /// Products over [fixed…, target], per frame, (I0+1)².
    fixed_products: Vec<f64>,
    /// Whether evaluations solve every frame (the instantaneous estimates) or
    /// only the last (the scalar estimate); see [`DofEngine::solve_every_frame`].
    all_frames: bool,
    constrained: [usize; 3],
    exponent_min: f64,
    resolution: f64,
    pub(super) max_index: i64,
    pub(super) cache: BTreeMap<i64, Evaluation>,
}

impl<'a> DofEngine<'a> {
    pub(super) fn new(
        problem: &'a DofProblem,
        transformer: &'a FrameTransformer,
        settings: &IdentifySettings,
    ) -> Self {
        let mut fixed_reps: Vec<FrameRepresentation> = problem
            .fixed_columns
            .iter()
            .map(|c| transformer.represent(c))
            .collect();
        fixed_reps.push(transformer.represent(&problem.target));
        let frames = transformer.layout().frames();
        let refs: Vec<&FrameRepresentation> = fixed_reps.iter().collect();
        let fixed_products = frame_products(&refs, &refs, frames);
        let i0 = problem.fixed_count();
        let span = settings.exponent_max - settings.exponent_min;
        DofEngine {
            problem,
            transformer,
            frames,
            fixed_reps,
            fixed_products,
            all_frames: false,
            // K0_dd ≥ 0 (last K column), s ≥ 0, t ≥ 0 (Eq. 47 after β = s + t, γ = s − t).
            constrained: [problem.coupled.len() - 1, i0, i0 + 1],
            exponent_min: settings.exponent_min,
            resolution: settings.exponent_resolution,
            max_index: (span / settings.exponent_resolution).round() as i64,
            cache: BTreeMap::new(),
        }
    }

    pub(super) fn exponent(&self, index: i64) -> f64 {
        self.exponent_min + index as f64 * self.resolution
    }

    fn compute(&self, index: i64) -> Result<Evaluation> {
        let n_exp = self.exponent(index);
        let problem = self.problem;
        let i0 = problem.fixed_count();
        let dim = i0 + 2;
        let width = dim + 1; // unknowns + target
        let nonlinear = problem.nonlinear_columns(n_exp);
        let nl_reps: Vec<FrameRepresentation> = nonlinear
            .iter()
            .map(|c| self.transformer.represent(c))
            .collect();
        let left: Vec<&FrameRepresentation> = nl_reps.iter().collect();
        let mut right: Vec<&FrameRepresentation> = self.fixed_reps[..i0].iter().collect();
        right.extend(nl_reps.iter());
        right.push(&self.fixed_reps[i0]);
        let frames = self.frames;
        let nl_products = frame_products(&left, &right, frames);
        let fixed_width = i0 + 1;
        // Column index in `right` order → index in the fixed block (target last).
        let fixed_index = |a: usize| if a < i0 { a } else { i0 };
        let mut cumulative = vec![0.0; width * width];
        let mut out = Vec::with_capacity(if self.all_frames { frames } else { 1 });
        for j in 0..frames {
            for a in 0..width {
                for b in 0..width {
                    let value = if a == i0 || a == i0 + 1 {
                        nl_products[(j * 2 + (a - i0)) * width + b]
                    } else if b == i0 || b == i0 + 1 {
                        nl_products[(j * 2 + (b - i0)) * width + a]
                    } else {
                        self.fixed_products
                            [(j * fixed_width + fixed_index(a)) * fixed_width + fixed_index(b)]
                    };
                    cumulative[a * width + b] += value;
                }
            }
            if self.all_frames || j + 1 == frames {
                let h: Vec<f64> = (0..dim)
                    .flat_map(|a| (0..dim).map(move |b| (a, b)))
                    .map(|(a, b)| cumulative[a * width + b])
                    .collect();
                let rhs: Vec<f64> = (0..dim).map(|a| cumulative[a * width + dim]).collect();
                let yy = cumulative[dim * width + dim];
                let solution = bounded_lsq_gram(&h, &rhs, yy, &self.constrained)?;
                out.push(FrameFit {
                    cost: solution.cost,
                    p: solution.p,
                    nonlinear_weight: cumulative[i0 * width + i0]
                        + cumulative[(i0 + 1) * width + i0 + 1],
                });
            }
        }
        Ok(Evaluation { frames: out })
    }

    /// From now on every frame is solved, and the evaluations made so far
    /// with the last frame only are made again with every frame (the same
    /// cumulative sums: their last frame is unchanged).  The scalar search
    /// needs the last frame only; the instantaneous estimates need every
    /// frame, but only for a DoF that passed the identifiability checks — a
    /// DoF that fails them (a linear building, say) costs one solve per trial
    /// exponent instead of one per frame (142 frames of 65 unknowns for the
    /// top storey of a 31-storey building: the stage's time).
    pub(super) fn solve_every_frame(&mut self) -> Result<()> {
        if self.all_frames {
            return Ok(());
        }
        self.all_frames = true;
        let partial: Vec<i64> = self
            .cache
            .iter()
            .filter(|(_, e)| e.frames.len() < self.frames)
            .map(|(k, _)| *k)
            .collect();
        for k in &partial {
            self.cache.remove(k);
        }
        self.evaluate(&partial)
    }

    /// Evaluates every index not yet cached (in parallel).
    pub(super) fn evaluate(&mut self, indices: &[i64]) -> Result<()> {
        let mut todo: Vec<i64> = indices
            .iter()
            .copied()
            .filter(|k| *k >= 0 && *k <= self.max_index && !self.cache.contains_key(k))
            .collect();
        todo.sort_unstable();
        todo.dedup();
        let results: Vec<Result<(i64, Evaluation)>> = todo
            .par_iter()
            .map(|&k| self.compute(k).map(|e| (k, e)))
            .collect();
        for r in results {
            let (k, e) = r?;
            self.cache.insert(k, e);
        }
        Ok(())
    }

    pub(super) fn scalar_cost(&self, k: i64) -> f64 {
        self.cache.get(&k).map_or(f64::INFINITY, |e| e.last().cost)
    }

    /// Successive refinement around `center` from `step` down to 1 (steps ÷5).
    pub(super) fn refine(
        &mut self,
        mut center: i64,
        mut step: i64,
        cost: impl Fn(&Self, i64) -> f64,
    ) -> Result<i64> {
        while step > 1 {
            let next = (step / 5).max(1);
            let reach = step / next;
            let points: Vec<i64> = (-reach..=reach).map(|m| center + m * next).collect();
            self.evaluate(&points)?;
            center = points
                .iter()
                .copied()
                .filter(|k| self.cache.contains_key(k))
                .min_by(|a, b| cost(self, *a).total_cmp(&cost(self, *b)).then(a.cmp(b)))
                .unwrap_or(center);
            step = next;
        }
        Ok(center)
    }
}

/// The scalar N search: J(N) at t = te on the coarse grid, then the best
/// `refine_candidates` local minima refined down to the resolution.
pub(super) struct ScalarSearch {
    /// Coarse grid (exponent indices) and its step.
    pub(super) grid: Vec<i64>,
    pub(super) coarse_step: i64,
    /// J at the coarse grid points.
    pub(super) coarse_costs: Vec<f64>,
    /// Index of N*, the refined minimum of lowest J (ties: the smaller N).
    pub(super) best_index: i64,
}

impl DofEngine<'_> {
    pub(super) fn search_scalar(&mut self, settings: &IdentifySettings) -> Result<ScalarSearch> {
        let coarse_step =
            ((settings.coarse_step / settings.exponent_resolution).round() as i64).max(1);
        let grid = coarse_grid(self.max_index, coarse_step);
        self.evaluate(&grid)?;
        let coarse_costs: Vec<f64> = grid.iter().map(|&k| self.scalar_cost(k)).collect();
        let candidates = local_minima(&grid, &coarse_costs);
        let mut best: Option<(i64, f64)> = None;
        for &(k, _) in candidates.iter().take(settings.refine_candidates) {
            let refined = self.refine(k, coarse_step, |e, i| e.scalar_cost(i))?;
            let cost = self.scalar_cost(refined);
            if best.is_none_or(|b| cost < b.1 || (cost == b.1 && refined < b.0)) {
                best = Some((refined, cost));
            }
        }
        let (best_index, _) = best
            .ok_or_else(|| Error::numerical("hysteresis: J(N) has no finite value on the grid"))?;
        Ok(ScalarSearch {
            grid,
            coarse_step,
            coarse_costs,
            best_index,
        })
    }
}

/// Coarse grid indices: multiples of `step` plus the upper end.
fn coarse_grid(max_index: i64, step: i64) -> Vec<i64> {
    let mut grid: Vec<i64> = (0..=max_index).step_by(step.max(1) as usize).collect();
    if grid.last() != Some(&max_index) {
        grid.push(max_index);
    }
    grid
}

/// Local minima of `values` over the grid (plateaus keep their first point).
fn local_minima(grid: &[i64], values: &[f64]) -> Vec<(i64, f64)> {
    let mut minima = Vec::new();
    for i in 0..grid.len() {
        let left = if i > 0 { values[i - 1] } else { f64::INFINITY };
        let right = values.get(i + 1).copied().unwrap_or(f64::INFINITY);
        if values[i] < left && values[i] <= right {
            minima.push((grid[i], values[i]));
        }
    }
    minima.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    minima
}
