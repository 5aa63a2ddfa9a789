//! The one early-stopping loop every model trains through: epochs up to a maximum, stop after
//! `patience` epochs without an improvement of more than `min_delta`, the best epoch's parameters
//! snapshotted and restored at the end, one progress bar on stderr.
//!
//! What an epoch does (mini-batches, loss, optimiser step) is the caller's closure; it returns the
//! epoch's stopping criterion (validation loss, or training loss without validation data) and the
//! progress message. An error from the closure (e.g. divergence) clears the bar and is returned.
use candle_core::{Tensor, Var};
use candle_nn::{AdamW, ParamsAdamW};

/// How much to draw on stderr.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    Bar,
    Hidden,
}

/// The stopping rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EarlyStopping {
    pub max_epochs: usize,
    /// Epochs without improvement before stopping.
    pub patience: usize,
    /// Improvement needed to count (the criterion must fall below `best - min_delta`).
    pub min_delta: f64,
}

/// What one epoch reports to the trainer.
#[derive(Clone, Debug, PartialEq)]
pub struct EpochOutcome {
    /// Smaller is better.
    pub criterion: f64,
    /// Shown after the bar.
    pub message: String,
}

/// What the loop did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StopReport {
    /// Epochs run.
    pub epochs: usize,
    /// Epoch whose parameters were restored (the last epoch when none ran).
    pub best_epoch: usize,
    pub stopped_early: bool,
}

/// AdamW over `vars` with candle's default betas and epsilon.
pub fn adamw(vars: Vec<Var>, learning_rate: f64, weight_decay: f64) -> candle_core::Result<AdamW> {
    use candle_nn::Optimizer;
    AdamW::new(
        vars,
        ParamsAdamW {
            lr: learning_rate,
            weight_decay,
            ..ParamsAdamW::default()
        },
    )
}

fn progress_bar(progress: Progress, len: usize, name: &str) -> indicatif::ProgressBar {
    match progress {
        Progress::Hidden => indicatif::ProgressBar::hidden(),
        Progress::Bar => {
            let pb = indicatif::ProgressBar::with_draw_target(
                Some(len as u64),
                indicatif::ProgressDrawTarget::stderr(),
            );
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "{prefix:>8} [{bar:30}] epoch {pos}/{len} {msg}",
            ) {
                pb.set_style(style.progress_chars("=> "));
            }
            pb.set_prefix(name.to_string());
            pb
        }
    }
}

fn snapshot(vars: &[Var]) -> candle_core::Result<Vec<Tensor>> {
    vars.iter().map(|v| v.as_tensor().copy()).collect()
}

fn restore(vars: &[Var], saved: &[Tensor]) -> candle_core::Result<()> {
    for (v, t) in vars.iter().zip(saved) {
        v.set(t)?;
    }
    Ok(())
}

impl EarlyStopping {
    /// Run `epoch(n)` for `n = 1, 2, ...` until the rule stops, then leave the best epoch's values
    /// in `vars`. `name` prefixes the progress bar.
    pub fn run<E, F>(
        &self,
        vars: &[Var],
        name: &str,
        progress: Progress,
        mut epoch_fn: F,
    ) -> Result<StopReport, E>
    where
        E: From<candle_core::Error>,
        F: FnMut(usize) -> Result<EpochOutcome, E>,
    {
        let pb = progress_bar(progress, self.max_epochs, name);
        let mut best: Option<(f64, usize, Vec<Tensor>)> = None;
        let mut since_best = 0usize;
        let mut stopped_early = false;
        let mut epoch = 0;
        while epoch < self.max_epochs {
            epoch += 1;
            let outcome = match epoch_fn(epoch) {
                Ok(o) => o,
                Err(e) => {
                    pb.finish_and_clear();
                    return Err(e);
                }
            };
            pb.set_message(outcome.message);
            pb.inc(1);
            let improved = match &best {
                None => true,
                Some((b, _, _)) => outcome.criterion < b - self.min_delta,
            };
            if improved {
                best = Some((outcome.criterion, epoch, snapshot(vars)?));
                since_best = 0;
            } else {
                since_best += 1;
                if since_best >= self.patience {
                    stopped_early = true;
                    break;
                }
            }
        }
        pb.finish_and_clear();
        let best_epoch = match best {
            Some((_, e, saved)) => {
                restore(vars, &saved)?;
                e
            }
            None => epoch,
        };
        Ok(StopReport {
            epochs: epoch,
            best_epoch,
            stopped_early,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use candle_core::Device;

    fn value(v: &Var) -> f32 {
        v.as_tensor().to_vec1::<f32>().unwrap()[0]
    }

    /// Each epoch writes its number into the variable and reports `losses[epoch - 1]`.
    fn run(rule: EarlyStopping, losses: &[f64]) -> (StopReport, f32) {
        let var = Var::from_vec(vec![0f32], 1, &Device::Cpu).unwrap();
        let vars = [var.clone()];
        let report = rule
            .run::<candle_core::Error, _>(&vars, "test", Progress::Hidden, |epoch| {
                var.set(&Tensor::from_vec(vec![epoch as f32], 1, &Device::Cpu)?)?;
                Ok(EpochOutcome {
                    criterion: losses[epoch - 1],
                    message: String::new(),
                })
            })
            .unwrap();
        (report, value(&var))
    }

    #[test]
    fn restores_the_best_epoch() {
        let rule = EarlyStopping {
            max_epochs: 5,
            patience: 10,
            min_delta: 0.0,
        };
        let (report, v) = run(rule, &[3.0, 1.0, 2.0, 1.5, 4.0]);
        assert_eq!(
            report,
            StopReport {
                epochs: 5,
                best_epoch: 2,
                stopped_early: false
            }
        );
        assert_eq!(v, 2.0, "the parameters of epoch 2 are restored");
    }

    #[test]
    fn patience_stops_and_min_delta_counts() {
        let rule = EarlyStopping {
            max_epochs: 100,
            patience: 2,
            min_delta: 0.1,
        };
        // Epoch 2 improves by less than min_delta: no improvement; epochs 2 and 3 exhaust patience.
        let (report, v) = run(rule, &[1.0, 0.95, 0.92, 0.1]);
        assert_eq!(
            report,
            StopReport {
                epochs: 3,
                best_epoch: 1,
                stopped_early: true
            }
        );
        assert_eq!(v, 1.0);
    }

    #[test]
    fn an_epoch_error_is_returned() {
        let rule = EarlyStopping {
            max_epochs: 4,
            patience: 4,
            min_delta: 0.0,
        };
        let r = rule.run::<candle_core::Error, _>(&[], "test", Progress::Hidden, |epoch| {
            if epoch == 2 {
                Err(candle_core::Error::Msg("diverged".into()))
            } else {
                Ok(EpochOutcome {
                    criterion: 1.0,
                    message: String::new(),
                })
            }
        });
        assert!(r.is_err());
    }
}
