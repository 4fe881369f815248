//! Per-update training metrics and their CSV form.
//!
//! Every learner reports an [`UpdateMetrics`] after each update (on-policy) or every
//! `log_interval` environment steps (off-policy). Quantities an algorithm does not have
//! (e.g. `approx_kl` for SAC) are `NaN` and written as empty CSV cells.

use std::io::Write;
use std::path::Path;

/// One row of training metrics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UpdateMetrics {
    /// Updates done so far (1-based).
    pub update: u64,
    /// Environment steps done so far (all environments).
    pub env_steps: u64,
    /// Wall-clock seconds spent in `learn` so far.
    pub wall_time: f64,
    /// Environment steps per second since the previous record (updates included).
    pub steps_per_second: f64,
    /// Episodes finished since the previous record.
    pub episodes: u64,
    /// Mean undiscounted return of those episodes.
    pub episode_return_mean: f64,
    /// Their standard deviation.
    pub episode_return_std: f64,
    /// Their mean length.
    pub episode_length_mean: f64,
    /// Policy loss.
    pub policy_loss: f64,
    /// Value-function loss (PPO, A2C, SAC v1's V network).
    pub value_loss: f64,
    /// Q-function loss (off-policy).
    pub q_loss: f64,
    /// Policy entropy (for SAC: the estimate `−E[log π]`).
    pub entropy: f64,
    /// Approximate KL divergence between old and new policy, `E[(r − 1) − log r]` (PPO).
    pub approx_kl: f64,
    /// Fraction of samples whose ratio was clipped (PPO).
    pub clip_fraction: f64,
    /// `1 − Var(R − V) / Var(R)` over the rollout (on-policy).
    pub explained_variance: f64,
    /// Mean Q value on the sampled batch (off-policy).
    pub mean_q: f64,
    /// Entropy temperature α (SAC).
    pub alpha: f64,
    /// Learning rate in use (the actor's, where actor and critic have their own).
    pub learning_rate: f64,
    /// Mean state value `V(s)` the critic predicts over the rollout (on-policy; in the
    /// learner's reward units, scaled when rewards are normalised).
    pub value_mean: f64,
    /// Mean environment reward per step since the previous record (as the env returns it,
    /// before any normalisation).
    pub reward_mean: f64,
    /// The KL penalty's coefficient `β` during the update (PPO with `kl_penalty`).
    pub kl_coef: f64,
    /// The critic's learning rate in use (equal to `learning_rate` unless the learner's
    /// `critic_learning_rate` is set).
    pub critic_learning_rate: f64,
}

impl UpdateMetrics {
    /// A record with every algorithm-specific field `NaN`.
    pub fn empty() -> UpdateMetrics {
        UpdateMetrics {
            episode_return_mean: f64::NAN,
            episode_return_std: f64::NAN,
            episode_length_mean: f64::NAN,
            policy_loss: f64::NAN,
            value_loss: f64::NAN,
            q_loss: f64::NAN,
            entropy: f64::NAN,
            approx_kl: f64::NAN,
            clip_fraction: f64::NAN,
            explained_variance: f64::NAN,
            mean_q: f64::NAN,
            alpha: f64::NAN,
            learning_rate: f64::NAN,
            value_mean: f64::NAN,
            reward_mean: f64::NAN,
            kl_coef: f64::NAN,
            critic_learning_rate: f64::NAN,
            ..Default::default()
        }
    }

    /// CSV column names.
    pub const COLUMNS: [&'static str; 22] = [
        "update",
        "env_steps",
        "wall_time",
        "steps_per_second",
        "episodes",
        "episode_return_mean",
        "episode_return_std",
        "episode_length_mean",
        "policy_loss",
        "value_loss",
        "q_loss",
        "entropy",
        "approx_kl",
        "clip_fraction",
        "explained_variance",
        "mean_q",
        "alpha",
        "learning_rate",
        "value_mean",
        "reward_mean",
        "kl_coef",
        "critic_learning_rate",
    ];

    /// The number of columns of files written before `value_mean`, `reward_mean` and
    /// `kl_coef` were logged (older logs).
    pub const COLUMNS_V1: usize = 18;

    /// The number of columns of files written before `critic_learning_rate` was logged
    /// (older logs).
    pub const COLUMNS_V2: usize = 21;

    /// The values in [`UpdateMetrics::COLUMNS`] order.
    pub fn values(&self) -> [f64; 22] {
        [
            self.update as f64,
            self.env_steps as f64,
            self.wall_time,
            self.steps_per_second,
            self.episodes as f64,
            self.episode_return_mean,
            self.episode_return_std,
            self.episode_length_mean,
            self.policy_loss,
            self.value_loss,
            self.q_loss,
            self.entropy,
            self.approx_kl,
            self.clip_fraction,
            self.explained_variance,
            self.mean_q,
            self.alpha,
            self.learning_rate,
            self.value_mean,
            self.reward_mean,
            self.kl_coef,
            self.critic_learning_rate,
        ]
    }

    /// The fields that must be identical between two runs with the same seed (everything
    /// but the timings), as bits.
    pub fn deterministic_bits(&self) -> Vec<u64> {
        let v = self.values();
        v.iter().enumerate().filter(|(i, _)| *i != 2 && *i != 3).map(|(_, x)| x.to_bits()).collect()
    }

    /// The CSV header line (no newline).
    pub fn csv_header() -> String {
        Self::COLUMNS.join(",")
    }

    /// Parses a line written by [`UpdateMetrics::csv_row`] (every field back to the same
    /// bits: finite numbers are written in Rust's shortest round-trip form); `None` for a
    /// line of another shape.
    pub fn parse_csv_row(line: &str) -> Option<UpdateMetrics> {
        let mut cells: Vec<&str> = line.split(',').collect();
        // Files written before `value_mean`, `reward_mean` and `kl_coef` existed have 18
        // columns, those before `critic_learning_rate` 21; the missing ones read as NaN.
        if cells.len() == Self::COLUMNS_V1 || cells.len() == Self::COLUMNS_V2 {
            cells.resize(Self::COLUMNS.len(), "");
        }
        if cells.len() != Self::COLUMNS.len() {
            return None;
        }
        let float = |c: &str| -> Option<f64> {
            match c {
                "" => Some(f64::NAN),
                "inf" => Some(f64::INFINITY),
                "-inf" => Some(f64::NEG_INFINITY),
                _ => c.parse().ok(),
            }
        };
        let mut v = [0.0; 22];
        for (i, c) in cells.iter().enumerate() {
            if !matches!(i, 0 | 1 | 4) {
                v[i] = float(c)?;
            }
        }
        Some(UpdateMetrics {
            update: cells[0].parse().ok()?,
            env_steps: cells[1].parse().ok()?,
            wall_time: v[2],
            steps_per_second: v[3],
            episodes: cells[4].parse().ok()?,
            episode_return_mean: v[5],
            episode_return_std: v[6],
            episode_length_mean: v[7],
            policy_loss: v[8],
            value_loss: v[9],
            q_loss: v[10],
            entropy: v[11],
            approx_kl: v[12],
            clip_fraction: v[13],
            explained_variance: v[14],
            mean_q: v[15],
            alpha: v[16],
            learning_rate: v[17],
            value_mean: v[18],
            reward_mean: v[19],
            kl_coef: v[20],
            critic_learning_rate: v[21],
        })
    }

    /// One CSV line (no newline); `NaN` becomes an empty cell.
    pub fn csv_row(&self) -> String {
        let v = self.values();
        let mut s = format!("{},{}", self.update, self.env_steps);
        for (i, x) in v.iter().enumerate().skip(2) {
            s.push(',');
            if i == 4 {
                s.push_str(&self.episodes.to_string());
            } else if x.is_finite() {
                s.push_str(&format!("{x}"));
            } else if !x.is_nan() {
                s.push_str(if *x > 0.0 { "inf" } else { "-inf" });
            }
        }
        s
    }
}

/// Running sums of finished episodes between two records (allocation-free).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EpisodeWindow {
    count: u64,
    sum: f64,
    sum_sq: f64,
    len_sum: f64,
}

impl EpisodeWindow {
    /// Adds a finished episode.
    pub fn push(&mut self, ret: f64, length: usize) {
        self.count += 1;
        self.sum += ret;
        self.sum_sq += ret * ret;
        self.len_sum += length as f64;
    }

    /// Writes the window's statistics into `m` and clears it (NaN if no episode finished).
    pub fn drain_into(&mut self, m: &mut UpdateMetrics) {
        m.episodes = self.count;
        if self.count > 0 {
            let n = self.count as f64;
            let mean = self.sum / n;
            m.episode_return_mean = mean;
            m.episode_return_std = (self.sum_sq / n - mean * mean).max(0.0).sqrt();
            m.episode_length_mean = self.len_sum / n;
        } else {
            m.episode_return_mean = f64::NAN;
            m.episode_return_std = f64::NAN;
            m.episode_length_mean = f64::NAN;
        }
        *self = EpisodeWindow::default();
    }
}

/// A CSV file of [`UpdateMetrics`] rows.
pub struct MetricsCsv {
    out: std::io::BufWriter<std::fs::File>,
}

impl MetricsCsv {
    /// Creates (truncates) `path` and writes the header.
    pub fn create(path: &Path) -> std::io::Result<MetricsCsv> {
        let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
        writeln!(out, "{}", UpdateMetrics::csv_header())?;
        Ok(MetricsCsv { out })
    }

    /// Opens an existing file written by [`MetricsCsv::create`] to append rows to it.
    pub fn append(path: &Path) -> std::io::Result<MetricsCsv> {
        let file = std::fs::OpenOptions::new().append(true).open(path)?;
        Ok(MetricsCsv { out: std::io::BufWriter::new(file) })
    }

    /// The rows of a file written by [`MetricsCsv::create`], in order; a line that does not
    /// parse (a row cut by a crash, a file of another kind) is an `InvalidData` error naming
    /// its line number.
    pub fn read(path: &Path) -> std::io::Result<Vec<UpdateMetrics>> {
        let text = std::fs::read_to_string(path)?;
        let mut lines = text.lines();
        let header = UpdateMetrics::csv_header();
        // The current header, or the 18 or 21 columns of files written before the later
        // columns existed (a resumed run rewrites its file under the current header). Every
        // row has the header's width: a row cut after 18 or 21 cells is not an older row.
        let older = |n: usize| UpdateMetrics::COLUMNS[..n].join(",");
        let (v1, v2) = (older(UpdateMetrics::COLUMNS_V1), older(UpdateMetrics::COLUMNS_V2));
        let width = match lines.next() {
            Some(h) if h == header => UpdateMetrics::COLUMNS.len(),
            Some(h) if h == v2 => UpdateMetrics::COLUMNS_V2,
            Some(h) if h == v1 => UpdateMetrics::COLUMNS_V1,
            _ => {
                return Err(std::io::Error::new(std::io::ErrorKind::InvalidData, "not a metrics.csv header"));
            }
        };
        lines
            .enumerate()
            .map(|(i, l)| {
                let row = (l.split(',').count() == width).then(|| UpdateMetrics::parse_csv_row(l)).flatten();
                row.ok_or_else(|| {
                    std::io::Error::new(
                        std::io::ErrorKind::InvalidData,
                        format!("line {}: not a metrics row", i + 2),
                    )
                })
            })
            .collect()
    }

    /// Appends a row.
    pub fn write(&mut self, m: &UpdateMetrics) -> std::io::Result<()> {
        writeln!(self.out, "{}", m.csv_row())
    }

    /// Flushes buffered rows.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }

    /// Flushes buffered rows and `fsync`s the file, so that every row written so far
    /// survives a crash (done before each periodic checkpoint).
    pub fn sync(&mut self) -> std::io::Result<()> {
        self.out.flush()?;
        self.out.get_ref().sync_data()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_row_and_window() {
        let mut w = EpisodeWindow::default();
        // Returns −100 and −200: mean −150, std 50; lengths 200 and 100: mean 150.
        w.push(-100.0, 200);
        w.push(-200.0, 100);
        let mut m = UpdateMetrics::empty();
        m.update = 3;
        m.env_steps = 600;
        w.drain_into(&mut m);
        assert_eq!(
            (m.episodes, m.episode_return_mean, m.episode_return_std, m.episode_length_mean),
            (2, -150.0, 50.0, 150.0)
        );
        let row = m.csv_row();
        assert_eq!(row.split(',').count(), UpdateMetrics::COLUMNS.len());
        assert!(row.starts_with("3,600,0,0,2,-150,50,150,,"), "{row}");
        let back = UpdateMetrics::parse_csv_row(&row).unwrap();
        assert_eq!(back.deterministic_bits(), m.deterministic_bits());
        let mut odd = m;
        (odd.wall_time, odd.mean_q, odd.alpha) = (0.1 + 0.2, f64::INFINITY, f64::NEG_INFINITY);
        let back = UpdateMetrics::parse_csv_row(&odd.csv_row()).unwrap();
        assert_eq!(back.values().map(f64::to_bits), odd.values().map(f64::to_bits));
        assert!(UpdateMetrics::parse_csv_row("3,600").is_none());
        // A row of the 18-column format reads with the three later columns NaN.
        let old_row = row.rsplitn(5, ',').nth(4).unwrap();
        let back = UpdateMetrics::parse_csv_row(old_row).unwrap();
        assert!(back.value_mean.is_nan() && back.reward_mean.is_nan() && back.kl_coef.is_nan());
        assert_eq!(back.episode_return_mean, -150.0);
        // And one of the 21-column format with the critic's learning rate NaN.
        let v2_row = row.rsplit_once(',').unwrap().0;
        let back = UpdateMetrics::parse_csv_row(v2_row).unwrap();
        assert!(back.critic_learning_rate.is_nan());
        assert_eq!(back.episode_return_mean, -150.0);
        assert!(UpdateMetrics::parse_csv_row(&row.replace("-150", "x")).is_none());
        w.drain_into(&mut m);
        assert_eq!(m.episodes, 0);
        assert!(m.episode_return_mean.is_nan());
    }

    #[test]
    fn a_file_reads_rows_of_its_headers_width_only() {
        let path = std::env::temp_dir().join(format!("centaur-metrics-{}.csv", std::process::id()));
        let mut m = UpdateMetrics::empty();
        (m.update, m.env_steps, m.learning_rate, m.critic_learning_rate) = (1, 64, 3e-4, 1e-3);
        let row = m.csv_row();
        let cut = row.rsplit_once(',').unwrap().0;
        let header = UpdateMetrics::csv_header();
        let v2_header = header.rsplit_once(',').unwrap().0;
        let write = |lines: &[&str]| std::fs::write(&path, lines.join("\n") + "\n").unwrap();
        write(&[&header, &row, &row]);
        let rows = MetricsCsv::read(&path).unwrap();
        assert_eq!((rows.len(), rows[1].critic_learning_rate), (2, 1e-3));
        // A current file whose last row was cut after 21 cells: an error, not an older row.
        write(&[&header, &row, cut]);
        let e = MetricsCsv::read(&path).unwrap_err();
        assert!(e.to_string().contains("line 3"), "{e}");
        // A file of the 21-column format reads, the critic's rate NaN.
        write(&[v2_header, cut]);
        let rows = MetricsCsv::read(&path).unwrap();
        assert!(rows[0].critic_learning_rate.is_nan() && rows[0].learning_rate == 3e-4);
        write(&[v2_header, &row]);
        assert!(MetricsCsv::read(&path).is_err());
        std::fs::remove_file(&path).unwrap();
    }
}
