//! Real-coded genetic algorithm (Goldberg 1989): tournament selection, blend (BLX-α)
//! crossover, Gaussian mutation with a shrinking scale, elitism. The seed point, when given,
//! is one individual of the first generation. Stops after `max_generations` or earlier by
//! `convergence` (stall of the best value, or a collapsed population).

use super::{
    argmin, evaluate_batch, Bounds, Convergence, Objective, OptimResult, Optimiser, Stall,
};
use crate::rng::Rng;

#[derive(Debug, Clone)]
pub struct GeneticAlgorithm {
    pub population: usize,
    pub max_generations: usize,
    /// Stop earlier: stall over a window of generations, or population collapse.
    pub convergence: Convergence,
    pub elite: usize,
    pub crossover_fraction: f64,
    pub blend_alpha: f64,
    pub tournament: usize,
    /// Initial mutation standard deviation in the unit cube (decreases linearly to 10 %).
    pub mutation_scale: f64,
}

impl Default for GeneticAlgorithm {
    fn default() -> Self {
        GeneticAlgorithm {
            population: 40,
            max_generations: 80,
            convergence: Convergence::default(),
            elite: 2,
            crossover_fraction: 0.8,
            blend_alpha: 0.3,
            tournament: 3,
            mutation_scale: 0.15,
        }
    }
}

impl Optimiser for GeneticAlgorithm {
    fn name(&self) -> &str {
        "GA"
    }

    fn minimise(
        &self,
        f: &Objective<'_>,
        bounds: &Bounds,
        seed_point: Option<&[f64]>,
        seed: u64,
    ) -> OptimResult {
        let dim = bounds.dim();
        let pop_size = self.population.max(4);
        let mut rng = Rng::new(seed);
        let mut pop: Vec<Vec<f64>> = (0..pop_size)
            .map(|_| (0..dim).map(|_| rng.uniform()).collect())
            .collect();
        if let Some(s) = seed_point {
            pop[0] = bounds.to_u(s);
        }
        let mut values = evaluate_batch(f, bounds, &pop);
        let mut evaluations = pop_size;
        let b = argmin(&values);
        let (mut best_u, mut best_v) = (pop[b].clone(), values[b]);
        let mut stall = Stall::new(self.convergence, best_v);
        let mut generation = 0;
        let mut converged = false;
        while generation < self.max_generations && !converged {
            generation += 1;
            let mut order: Vec<usize> = (0..pop_size).collect();
            order.sort_by(|&a, &c| values[a].total_cmp(&values[c]).then(a.cmp(&c)));
            let mut next: Vec<Vec<f64>> = order
                .iter()
                .take(self.elite.min(pop_size))
                .map(|&i| pop[i].clone())
                .collect();
            let progress = generation as f64 / self.max_generations as f64;
            let sigma = self.mutation_scale * (1.0 - 0.9 * progress);
            let pick = |rng: &mut Rng| -> usize {
                let mut winner = rng.below(pop_size);
                for _ in 1..self.tournament {
                    let c = rng.below(pop_size);
                    if values[c] < values[winner] {
                        winner = c;
                    }
                }
                winner
            };
            while next.len() < pop_size {
                let p1 = pick(&mut rng);
                let mut child = pop[p1].clone();
                if rng.uniform() < self.crossover_fraction {
                    let p2 = pick(&mut rng);
                    for d in 0..dim {
                        let (lo, hi) = (pop[p1][d].min(pop[p2][d]), pop[p1][d].max(pop[p2][d]));
                        let span = hi - lo;
                        child[d] = rng
                            .uniform_in(lo - self.blend_alpha * span, hi + self.blend_alpha * span);
                    }
                }
                for v in child.iter_mut() {
                    if rng.uniform() < 1.0 / dim.max(1) as f64 {
                        *v += sigma * rng.normal_uncached();
                    }
                    *v = v.clamp(0.0, 1.0);
                }
                next.push(child);
            }
            pop = next;
            values = evaluate_batch(f, bounds, &pop);
            evaluations += pop_size;
            let b = argmin(&values);
            if values[b] < best_v {
                best_v = values[b];
                best_u = pop[b].clone();
            }
            converged = stall.update(best_v) || self.convergence.collapsed(&pop);
        }
        OptimResult {
            x: bounds.to_x(&best_u),
            value: best_v,
            evaluations,
            iterations: generation,
        }
    }
}
