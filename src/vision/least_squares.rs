//! Levenberg-Marquardt for small fixed-size image models (a particle profile,
//! the probe silhouette): weighted samples (x, y, value, weight), a model that
//! returns its value and gradient. Hand-written because it runs once per
//! particle in the hot loop: fixed-size, allocation-free normal equations
//! beat a general solver, and the code is short.

use nalgebra::{SMatrix, SVector};
use thiserror::Error;

/// One weighted observation: pixel x, pixel y, value, weight (1 / variance, relative).
pub type Sample = (f64, f64, f64, f64);

/// Why a fit produced no estimate.
#[derive(Debug, Error, PartialEq)]
pub enum FitError {
    /// Fewer samples than parameters + 1.
    #[error("{got} samples cannot fit {params} parameters")]
    TooFewSamples { got: usize, params: usize },
    /// The normal matrix is singular: the data do not constrain the model.
    #[error("the fit is not constrained by the data (singular normal matrix)")]
    Singular,
    /// The model produced a non-finite value.
    #[error("the model evaluated to a non-finite value")]
    NotFinite,
    /// The caller's give-up rule stopped a fit still running (the reason is
    /// the rule's).
    #[error("fit given up: {0}")]
    GivenUp(&'static str),
}

/// A give-up rule for [`levenberg_marquardt_with`]: after an accepted step,
/// called with the iterations done, the parameters and the residual
/// variance; `Some(reason)` ends the fit with [`FitError::GivenUp`].
pub type GiveUp<'a, const N: usize> =
    &'a dyn Fn(usize, &SVector<f64, N>, f64) -> Option<&'static str>;

/// The rule that never gives up.
pub fn never_give_up<const N: usize>(
    _: usize,
    _: &SVector<f64, N>,
    _: f64,
) -> Option<&'static str> {
    None
}

/// A converged (or best-effort) fit.
#[derive(Debug, Clone)]
pub struct FitOutcome<const N: usize> {
    /// Best parameters.
    pub params: SVector<f64, N>,
    /// Parameter covariance, scaled by the residual variance.
    pub covariance: SMatrix<f64, N, N>,
    /// Weighted residual sum of squares.
    pub rss: f64,
    /// Residual variance per unit weight (rss / (n - N)).
    pub residual_variance: f64,
    /// Iterations used.
    pub iterations: usize,
}

/// The normal equations of a weighted least-squares problem at one point:
/// J^T W J, J^T W r and the weighted residual sum of squares.
#[derive(Debug, Clone)]
pub struct NormalEquations<const N: usize> {
    /// J^T W J (whole symmetric matrix).
    pub jtj: SMatrix<f64, N, N>,
    /// J^T W r, r = value - model.
    pub jtr: SVector<f64, N>,
    /// sum w r^2.
    pub rss: f64,
    /// Samples that carry information at this point: all of them, but a
    /// censored one the model reaches (a saturated pixel, fitted exactly),
    /// which adds no residual and so no degree of freedom either.
    pub observations: usize,
}

/// A least-squares problem evaluated in two parts, so that a trial point the
/// fit rejects costs only its residuals: `rss(p)` evaluates at `p` and keeps
/// what the normal equations need; `normal_equations()` then gives them at
/// that last point.
pub trait Evaluation<const N: usize> {
    /// Weighted residual sum of squares at `p`.
    fn rss(&mut self, p: &SVector<f64, N>) -> f64;
    /// The normal equations at the point last passed to `rss`.
    fn normal_equations(&mut self) -> NormalEquations<N>;
}

/// Weighted samples and a per-sample model: one pass gives rss and normal
/// equations together (the model returns its value and gradient at once).
struct SampleModel<'a, const N: usize, F> {
    samples: &'a [Sample],
    model_at: F,
    last: Option<NormalEquations<N>>,
}

impl<const N: usize, F, M> Evaluation<N> for SampleModel<'_, N, F>
where
    F: Fn(&SVector<f64, N>) -> M,
    M: Fn(f64, f64, &mut SVector<f64, N>) -> f64,
{
    fn rss(&mut self, p: &SVector<f64, N>) -> f64 {
        let model = (self.model_at)(p);
        let mut grad = SVector::<f64, N>::zeros();
        let mut jtj = SMatrix::<f64, N, N>::zeros();
        let mut jtr = SVector::<f64, N>::zeros();
        let mut rss = 0.0;
        for &(x, y, v, w) in self.samples {
            let m = model(x, y, &mut grad);
            let r = v - m;
            rss += w * r * r;
            jtr += grad * (w * r);
            jtj.syger(w, &grad, &grad, 1.0);
        }
        // syger fills the lower triangle only (enough for the Cholesky step);
        // the covariance is an inverse of the whole matrix.
        jtj.fill_upper_triangle_with_lower_triangle();
        self.last = Some(NormalEquations {
            jtj,
            jtr,
            rss,
            observations: self.samples.len(),
        });
        rss
    }

    fn normal_equations(&mut self) -> NormalEquations<N> {
        self.last
            .take()
            .expect("normal_equations follows an rss evaluation")
    }
}

/// Minimises sum w (value - model)^2 from `init`. `model_at(p)` prepares the
/// model at parameters `p` (work shared by every sample, such as a sine and
/// cosine, is done there once per evaluation); the prepared model, called as
/// `m(x, y, grad)`, returns the value at (x, y) and writes d model / d p into
/// `grad`.
pub fn levenberg_marquardt<const N: usize, F, M>(
    samples: &[Sample],
    init: SVector<f64, N>,
    max_iterations: usize,
    model_at: F,
) -> Result<FitOutcome<N>, FitError>
where
    F: Fn(&SVector<f64, N>) -> M,
    M: Fn(f64, f64, &mut SVector<f64, N>) -> f64,
{
    let mut problem = SampleModel {
        samples,
        model_at,
        last: None,
    };
    levenberg_marquardt_with(
        samples.len(),
        init,
        max_iterations,
        &[],
        &never_give_up,
        &mut problem,
    )
}

/// A Gauss-Newton step whose predicted rss decrease is below this many
/// residual variances moves the parameters by at most sqrt(this) = 1 standard
/// error in all (the decrease is the step's squared Mahalanobis length): it is
/// taken without a further evaluation and ends the fit. Convergence is
/// quadratic from there: on the 100-sphere bench frame the step after one
/// predicting ~1 variance predicts 3e-4..5e-3 variances, so the point left is
/// within ~0.07 standard errors of the minimum (under 0.5 % of the variance).
/// The earlier threshold, 1e-3 variances, cost one more evaluation per fit
/// (693 -> 506 evaluations of the 118 fits on the bench frame).
const CONVERGED_DECREASE: f64 = 1.0;

/// A Gauss-Newton step (no damping) predicting less than this many residual
/// variances that does not lower the rss is below the evaluation's rounding
/// (f32 batch models): converged.
const ROUNDING_DECREASE: f64 = 1e-2;

/// An accepted step that moves every watched parameter by less than this
/// fraction of its standard error ends the fit.
const WATCHED_STEP: f64 = 0.02;

/// [`levenberg_marquardt`] for a problem of `n_samples` observations
/// evaluated through [`Evaluation`] (a batch evaluation over the whole
/// window, see `pixel_window`): the normal equations are asked for only at
/// the points the fit keeps.
///
/// Stops when the step predicted by the linearised model would lower the rss
/// by less than `CONVERGED_DECREASE` residual variances (that step is taken
/// without a further evaluation), when an accepted step lowers the rss by a
/// relative 1e-8, when an accepted step moves every `watched` parameter (the
/// ones the caller reports; none when empty) by less than
/// `WATCHED_STEP` of its standard error, or when no trial step lowers the rss.
/// The watched rule ends fits whose nuisance parameters crawl along a flat
/// valley (a wide core trading off against the background) for dozens of
/// iterations while the centre no longer moves. `give_up` is asked after
/// every accepted step that does not end the fit (a caller that will reject
/// the fit's answer anyway can stop paying for it).
pub fn levenberg_marquardt_with<const N: usize>(
    n_samples: usize,
    init: SVector<f64, N>,
    max_iterations: usize,
    watched: &[usize],
    give_up: GiveUp<N>,
    problem: &mut impl Evaluation<N>,
) -> Result<FitOutcome<N>, FitError> {
    if n_samples <= N {
        return Err(FitError::TooFewSamples {
            got: n_samples,
            params: N,
        });
    }
    let mut p = init;
    if !problem.rss(&p).is_finite() {
        return Err(FitError::NotFinite);
    }
    let mut at_p = problem.normal_equations();
    let mut lambda = 1e-3;
    let mut iterations = 0;
    for _ in 0..max_iterations {
        iterations += 1;
        let mut improved = false;
        let variance = at_p.residual_variance();
        for trial_no in 0..8 {
            let mut a = at_p.jtj;
            for i in 0..N {
                a[(i, i)] += lambda * at_p.jtj[(i, i)].max(1e-12);
            }
            let Some(step) = a.cholesky().map(|c| c.solve(&at_p.jtr)) else {
                lambda *= 10.0;
                continue;
            };
            let trial = p + step;
            // Predicted decrease of the linearised model, 2 s.Jr - s.JJ s; only
            // meaningful while the step is close to Gauss-Newton's.
            let predicted = 2.0 * step.dot(&at_p.jtr) - step.dot(&(at_p.jtj * step));
            if trial_no == 0
                && lambda <= 1e-2
                && predicted.abs() < CONVERGED_DECREASE * variance
                && trial.iter().all(|v| v.is_finite())
            {
                return finish(trial, &at_p, iterations);
            }
            let trial_rss = problem.rss(&trial);
            if trial_rss.is_finite() && trial_rss < at_p.rss {
                let at_trial = problem.normal_equations();
                // A relative decrease of 1e-8 moves a parameter by ~1e-4 of its
                // standard error: converged, and stopping here saves the rounds
                // of rejected trials that would otherwise end the fit.
                let mut small = step.norm() < 1e-7 * (1.0 + p.norm())
                    || at_p.rss - at_trial.rss < 1e-8 * at_p.rss;
                if !small && !watched.is_empty() {
                    small = at_p.jtj.try_inverse().is_some_and(|inv| {
                        watched.iter().all(|&i| {
                            i < N && step[i].powi(2) < WATCHED_STEP.powi(2) * variance * inv[(i, i)]
                        })
                    });
                }
                p = trial;
                at_p = at_trial;
                lambda = (lambda * 0.2).max(1e-9);
                improved = true;
                if small {
                    return finish(p, &at_p, iterations);
                }
                if let Some(reason) = give_up(iterations, &p, at_p.residual_variance()) {
                    return Err(FitError::GivenUp(reason));
                }
                break;
            }
            // A Gauss-Newton step this small that does not lower the rss is
            // below the evaluation's rounding (f32 batch models): converged.
            if trial_no == 0 && lambda <= 1e-2 && predicted.abs() < ROUNDING_DECREASE * variance {
                return finish(p, &at_p, iterations);
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    finish(p, &at_p, iterations)
}

impl<const N: usize> NormalEquations<N> {
    /// rss per degree of freedom (the observations beyond the parameters;
    /// at least one, [`finish`] refuses fewer).
    fn residual_variance(&self) -> f64 {
        self.rss / self.observations.saturating_sub(N).max(1) as f64
    }
}

fn finish<const N: usize>(
    params: SVector<f64, N>,
    at_p: &NormalEquations<N>,
    iterations: usize,
) -> Result<FitOutcome<N>, FitError> {
    if at_p.observations <= N {
        return Err(FitError::TooFewSamples {
            got: at_p.observations,
            params: N,
        });
    }
    let (jtj, rss) = (at_p.jtj, at_p.rss);
    let inv = jtj.try_inverse().ok_or(FitError::Singular)?;
    let residual_variance = at_p.residual_variance();
    let covariance = inv * residual_variance;
    if !(0..N).all(|i| covariance[(i, i)].is_finite() && covariance[(i, i)] >= 0.0) {
        return Err(FitError::Singular);
    }
    Ok(FitOutcome {
        params,
        covariance,
        rss,
        residual_variance,
        iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y = a exp(-b x) at parameters (a, b), with its gradient.
    fn decay_model(p: &SVector<f64, 2>) -> impl Fn(f64, f64, &mut SVector<f64, 2>) -> f64 + use<> {
        let p = *p;
        move |x, _y, g| {
            let e = (-p[1] * x).exp();
            g[0] = e;
            g[1] = -p[0] * x * e;
            p[0] * e
        }
    }

    #[test]
    fn fits_an_exponential_and_reports_too_few_samples() {
        let samples: Vec<Sample> = (0..20)
            .map(|i| {
                let x = i as f64 * 0.2;
                (
                    x,
                    0.0,
                    3.0 * (-0.7 * x).exp() + if i % 2 == 0 { 1e-3 } else { -1e-3 },
                    1.0,
                )
            })
            .collect();
        let model = decay_model;
        let fit =
            levenberg_marquardt(&samples, SVector::<f64, 2>::new(1.0, 0.1), 50, model).unwrap();
        assert!((fit.params[0] - 3.0).abs() < 1e-2 && (fit.params[1] - 0.7).abs() < 1e-2);
        assert!(matches!(
            levenberg_marquardt(&samples[..2], SVector::<f64, 2>::new(1.0, 0.1), 5, model),
            Err(FitError::TooFewSamples { .. })
        ));
    }

    #[test]
    fn covariance_is_the_inverse_of_the_whole_normal_matrix() {
        // y = a + b x with x far from 0: a and b are strongly correlated, so
        // var(a) from the full inverse is far above 1 / (J^T J)_aa.
        let samples: Vec<Sample> = (0..10)
            .map(|i| {
                let x = 100.0 + i as f64;
                (
                    x,
                    0.0,
                    2.0 + 0.5 * x + if i % 2 == 0 { 0.1 } else { -0.1 },
                    1.0,
                )
            })
            .collect();
        let model = |p: &SVector<f64, 2>| {
            let p = *p;
            move |x: f64, _y: f64, g: &mut SVector<f64, 2>| {
                g[0] = 1.0;
                g[1] = x;
                p[0] + p[1] * x
            }
        };
        let fit =
            levenberg_marquardt(&samples, SVector::<f64, 2>::new(0.0, 0.0), 50, model).unwrap();
        let n = samples.len() as f64;
        let (sx, sxx) = samples
            .iter()
            .fold((0.0, 0.0), |(a, b), s| (a + s.0, b + s.0 * s.0));
        // (X^T X)^-1 for a straight line: var(a) = sxx / (n sxx - sx^2) per unit variance.
        let want = fit.residual_variance * sxx / (n * sxx - sx * sx);
        assert!(
            (fit.covariance[(0, 0)] / want - 1.0).abs() < 1e-6,
            "{} vs {want}",
            fit.covariance[(0, 0)]
        );
        assert!((fit.covariance[(0, 1)] - fit.covariance[(1, 0)]).abs() < 1e-9 * want);
    }

    #[test]
    fn a_give_up_rule_stops_a_running_fit_and_only_after_its_patience() {
        // y = 3 exp(-0.7 x) from a far start: the fit takes several steps.
        let samples: Vec<Sample> = (0..20)
            .map(|i| {
                (
                    i as f64 * 0.25,
                    0.0,
                    3.0 * (-0.7 * i as f64 * 0.25).exp(),
                    1.0,
                )
            })
            .collect();
        let fit_with = |give_up: GiveUp<2>| {
            let mut problem = SampleModel {
                samples: &samples,
                model_at: decay_model,
                last: None,
            };
            levenberg_marquardt_with(
                samples.len(),
                SVector::<f64, 2>::new(1.0, 0.1),
                50,
                &[],
                give_up,
                &mut problem,
            )
        };
        let full = fit_with(&never_give_up).unwrap();
        assert!(full.iterations >= 3, "{}", full.iterations);
        // Asked after every accepted step with the iterations done so far.
        let asked = std::cell::RefCell::new(vec![]);
        let stop_at_2 = |it: usize, _: &SVector<f64, 2>, v: f64| {
            assert!(v.is_finite() && v >= 0.0);
            asked.borrow_mut().push(it);
            (it >= 2).then_some("stopped")
        };
        assert_eq!(
            fit_with(&stop_at_2).unwrap_err(),
            FitError::GivenUp("stopped")
        );
        assert_eq!(*asked.borrow(), vec![1, 2]);
        // A rule that never fires leaves the fit as it was.
        let patient = |it: usize, _: &SVector<f64, 2>, _: f64| (it > 1000).then_some("never");
        let same = fit_with(&patient).unwrap();
        assert_eq!(same.params, full.params);
        assert_eq!(same.iterations, full.iterations);
    }
}
