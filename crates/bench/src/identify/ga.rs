//! The paper's genetic algorithm, exactly as section 2.3 states it: floating-point encoding
//! (one real gene per unknown, linear in its range), roulette-wheel selection, single-point
//! crossover with probability 0.5, adaptive mutation, population 25, at most 100
//! generations, and an early stop once 10 consecutive generations fail to improve the best
//! cost by 1 % over the previous generation's.
//!
//! What section 2.3 leaves open, chosen here:
//! - fitness f = 1/J for the roulette wheel (J is minimised);
//! - adaptive mutation after Srinivas & Patnaik (IEEE Trans. SMC 24(4), 1994): each gene of a
//!   child mutates with probability p_m = k (f_max - f') / (f_max - f_avg) when the better
//!   parent's fitness f' is at least the population mean, else p_m = k, with k = 0.5; the
//!   mutation step is Michalewicz's non-uniform one, which shrinks as the generations pass:
//!   y -> y + (1 - y) d or y - y d, d = 1 - r^((1 - g/G)^2), r uniform in [0, 1);
//! - the 2 best individuals pass unchanged to the next generation (5 % elitism, the usual
//!   GA default), so the best cost never gets worse; they are not simulated again.
//! - "number of genes is 5" in section 2.3 does not match its three unknowns; here there is
//!   one gene per fitted parameter.
//!
//! At most 25 + 99 x 23 = 2302 simulations (within the paper's 25 x 100 = 2500 budget).

use super::{Evaluator, Outcome};
use crate::numerics::rng::{seeded, Rng};
use rand::Rng as _;

pub const POPULATION: usize = 25;
pub const MAX_GENERATIONS: usize = 100;
pub const CROSSOVER_PROBABILITY: f64 = 0.5;
pub const STALL_GENERATIONS: usize = 10;
pub const MIN_IMPROVEMENT: f64 = 0.01;
const ELITE: usize = 2;
/// Srinivas-Patnaik mutation constant k (their k2 = k4 = 0.5).
const MUTATION_K: f64 = 0.5;
/// Shape exponent of the non-uniform mutation.
const NON_UNIFORM_B: f64 = 2.0;
/// Most simulations one run can take.
pub const MAX_SIMULATIONS: usize = POPULATION + (MAX_GENERATIONS - 1) * (POPULATION - ELITE);

/// Runs the GA in unit coordinates; every random draw comes from one ChaCha8 stream.
pub fn run(eval: &Evaluator, seed: u64) -> Outcome {
    let n = eval.dim();
    let mut rng = seeded(seed);
    let mut pop: Vec<Vec<f64>> = (0..POPULATION)
        .map(|_| (0..n).map(|_| rng.gen::<f64>()).collect())
        .collect();
    let mut cost = eval.costs(&pop);
    let mut history = vec![min(&cost)];
    eval.report(history[0]);
    let mut stall = 0;
    for generation in 1..MAX_GENERATIONS {
        let order = ranking(&cost);
        let mut next: Vec<Vec<f64>> = order[..ELITE].iter().map(|&i| pop[i].clone()).collect();
        let mut next_cost: Vec<f64> = order[..ELITE].iter().map(|&i| cost[i]).collect();
        let children = offspring(&pop, &fitness(&cost), generation, &mut rng);
        next_cost.extend(eval.costs(&children));
        next.extend(children);
        pop = next;
        cost = next_cost;
        let previous = *history.last().expect("one generation at least");
        let best = min(&cost);
        history.push(best);
        eval.report(best);
        let improvement = if previous.is_finite() && previous > 0.0 {
            (previous - best) / previous
        } else {
            1.0
        };
        stall = if improvement < MIN_IMPROVEMENT {
            stall + 1
        } else {
            0
        };
        if stall >= STALL_GENERATIONS {
            break;
        }
    }
    let i = ranking(&cost)[0];
    Outcome {
        best: pop[i].clone(),
        cost: cost[i],
        history,
    }
}

/// The generation's children besides the elite: parent pairs drawn by roulette on
/// `fitness`, single-point crossover with `CROSSOVER_PROBABILITY`, then adaptive
/// non-uniform mutation (the rate of the fitter parent, Srinivas & Patnaik).
fn offspring(pop: &[Vec<f64>], fitness: &[f64], generation: usize, rng: &mut Rng) -> Vec<Vec<f64>> {
    let n = pop[0].len();
    let f_max = fitness.iter().cloned().fold(0.0, f64::max);
    let f_avg = fitness.iter().sum::<f64>() / fitness.len() as f64;
    let mut children = Vec::with_capacity(POPULATION - ELITE);
    while children.len() < POPULATION - ELITE {
        let (i, j) = (roulette(fitness, rng), roulette(fitness, rng));
        let (mut c1, mut c2) = (pop[i].clone(), pop[j].clone());
        if n > 1 && rng.gen::<f64>() < CROSSOVER_PROBABILITY {
            let cut = rng.gen_range(1..n);
            for g in cut..n {
                std::mem::swap(&mut c1[g], &mut c2[g]);
            }
        }
        let f_parent = fitness[i].max(fitness[j]);
        let p_m = if f_parent >= f_avg && f_max > f_avg {
            MUTATION_K * (f_max - f_parent) / (f_max - f_avg)
        } else {
            MUTATION_K
        };
        for child in [c1, c2] {
            if children.len() < POPULATION - ELITE {
                children.push(mutate(child, p_m, generation, rng));
            }
        }
    }
    children
}

fn min(cost: &[f64]) -> f64 {
    cost.iter().cloned().fold(f64::INFINITY, f64::min)
}

/// Indices from the lowest cost up (stable, so ties keep their order).
fn ranking(cost: &[f64]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..cost.len()).collect();
    idx.sort_by(|&a, &b| cost[a].total_cmp(&cost[b]));
    idx
}

/// Roulette-wheel fitness f = 1/J (0 for a failed simulation); a cost of exactly zero (a
/// noise-free recording matched exactly) is floored at 1e-12 of the median finite cost.
fn fitness(cost: &[f64]) -> Vec<f64> {
    let finite: Vec<f64> = cost.iter().cloned().filter(|c| c.is_finite()).collect();
    let floor = 1e-12 * crate::numerics::stats::median(&finite) + f64::MIN_POSITIVE;
    cost.iter()
        .map(|&c| {
            if c.is_finite() {
                1.0 / c.max(floor)
            } else {
                0.0
            }
        })
        .collect()
}

/// One spin of the roulette wheel: index i with probability f_i / sum f.
fn roulette(fitness: &[f64], rng: &mut Rng) -> usize {
    let total: f64 = fitness.iter().sum();
    if total <= 0.0 || !total.is_finite() {
        return rng.gen_range(0..fitness.len());
    }
    let mut spin = rng.gen::<f64>() * total;
    for (i, f) in fitness.iter().enumerate() {
        spin -= f;
        if spin < 0.0 {
            return i;
        }
    }
    fitness.len() - 1
}

/// Non-uniform mutation of each gene with probability p_m (genes live in [0, 1]).
fn mutate(mut genes: Vec<f64>, p_m: f64, generation: usize, rng: &mut Rng) -> Vec<f64> {
    let shrink = (1.0 - generation as f64 / MAX_GENERATIONS as f64).powf(NON_UNIFORM_B);
    for y in genes.iter_mut() {
        if rng.gen::<f64>() < p_m {
            let d = 1.0 - rng.gen::<f64>().powf(shrink);
            *y = if rng.gen::<bool>() {
                *y + (1.0 - *y) * d
            } else {
                *y - *y * d
            };
            *y = y.clamp(0.0, 1.0);
        }
    }
    genes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roulette_follows_fitness() {
        let mut rng = seeded(7);
        let f = fitness(&[1.0, 3.0, f64::INFINITY]);
        assert_eq!(f[2], 0.0);
        let picks: Vec<usize> = (0..4000).map(|_| roulette(&f, &mut rng)).collect();
        let share0 = picks.iter().filter(|&&i| i == 0).count() as f64 / 4000.0;
        assert!((share0 - 0.75).abs() < 0.03, "share of the best {share0}");
        assert!(!picks.contains(&2));
    }

    #[test]
    fn mutation_stays_in_the_box_and_shrinks() {
        let mut rng = seeded(1);
        let mut early = 0.0;
        let mut late = 0.0;
        for _ in 0..2000 {
            let a = mutate(vec![0.5], 1.0, 1, &mut rng)[0];
            let b = mutate(vec![0.5], 1.0, 95, &mut rng)[0];
            assert!((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b));
            early += (a - 0.5).abs();
            late += (b - 0.5).abs();
        }
        assert!(late < 0.2 * early, "late steps {late} vs early {early}");
    }
}
