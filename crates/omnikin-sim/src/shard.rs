//! Splitting a Monte-Carlo run across processes or machines, and reading the parts back.
//!
//! Trial `i` of a run depends only on `(seed, i)` ([`crate::trial_rng`]), so the trials can
//! be simulated anywhere. Shard `K` of `N` ([`Shard`]) simulates the trials
//! [`Shard::range`]: `⌊(K−1)·T/N⌋ .. ⌊K·T/N⌋` of `T`, contiguous, every trial in exactly one
//! shard. What it keeps of each trial for the metrics is the [`crate::trial_run`]: the
//! tracked positions and the true headings, written bit for bit to a runs file
//! ([`RunsWriter`], [`RunsFile`]). The metrics cannot be summed per shard and added up: the
//! sums are floating-point (the order of the additions changes the last bits) and the spread
//! around the mean needs the mean of *all* trials first. So a merge reads every trial's run
//! back, in trial order, into the same evaluation as one run ([`crate::evaluate_runs`]) —
//! bit-identical figures, at the cost of the metrics' pass (no simulation).
//!
//! # Runs file (`runs.bin`, little-endian)
//! | bytes | content |
//! |---|---|
//! | 8 | magic `OMKRUNS1` |
//! | 8 | `samples` (u64): positions per trial |
//! | 8 | `first` (u64): index of the first trial in the file |
//! | 8 | `count` (u64): trials in the file |
//! | 24 · samples per trial | `x, y, heading` (f64) per sample: tracked position, m (world frame), true heading, rad (unwrapped) |

use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::metrics::Run;

/// Shard `index` of `count` (1-based: `1 ≤ index ≤ count`), written `K/N` on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// `K`, 1 to `count`.
    pub index: usize,
    /// `N`, the number of shards, ≥ 1.
    pub count: usize,
}

/// Why a shard or a runs file was refused.
#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    /// `K/N` is malformed or out of range.
    #[error("--shard \"{text}\": {rule}")]
    Parse {
        /// What was given.
        text: String,
        /// The rule it breaks.
        rule: String,
    },
    /// More shards than trials.
    #[error(
        "--shard {index}/{count}: {count} shards of {trials} trials; N must be at most the number of trials ({what}), so that every shard has a trial"
    )]
    TooMany {
        /// `K`.
        index: usize,
        /// `N`.
        count: usize,
        /// Trials to split.
        trials: usize,
        /// The flag the trials come from.
        what: &'static str,
    },
    /// A runs file could not be read or is not what its shard says.
    #[error("{file}: {why}")]
    Runs {
        /// The file.
        file: String,
        /// What is wrong.
        why: String,
    },
}

/// Most shards of one run (a bound on the work `merge` does per shard and on file handles).
pub const MAX_SHARDS: usize = 10_000;

impl Shard {
    /// Parses `K/N` (`1 ≤ K ≤ N ≤` [`MAX_SHARDS`]).
    ///
    /// # Errors
    /// [`ShardError::Parse`] naming the rule broken.
    pub fn parse(text: &str) -> Result<Self, ShardError> {
        let err = |rule: String| ShardError::Parse {
            text: text.to_string(),
            rule,
        };
        let (k, n) = text
            .trim()
            .split_once('/')
            .ok_or_else(|| err("expected K/N, e.g. 2/4 (shard K of N, 1-based)".into()))?;
        let num = |s: &str, what: &str| {
            s.trim().parse::<usize>().map_err(|_| {
                err(format!(
                    "{what} must be a whole number ≥ 1, got \"{}\"",
                    s.trim()
                ))
            })
        };
        let (index, count) = (num(k, "K")?, num(n, "N")?);
        if count == 0 || count > MAX_SHARDS {
            return Err(err(format!(
                "N must be between 1 and {MAX_SHARDS} (omnikin_sim::shard::MAX_SHARDS), got {count}"
            )));
        }
        if index == 0 || index > count {
            return Err(err(format!(
                "K must be between 1 and N = {count} (shards are numbered from 1), got {index}"
            )));
        }
        Ok(Shard { index, count })
    }

    /// Checks that `trials` (from the flag `what`) can be split into [`Shard::count`] shards
    /// with at least one trial each.
    ///
    /// # Errors
    /// [`ShardError::TooMany`].
    pub fn check(&self, trials: usize, what: &'static str) -> Result<(), ShardError> {
        if self.count > trials {
            return Err(ShardError::TooMany {
                index: self.index,
                count: self.count,
                trials,
                what,
            });
        }
        Ok(())
    }

    /// The trials of this shard out of `trials`: `⌊(K−1)·T/N⌋ .. ⌊K·T/N⌋` (empty when
    /// `N > T`). The ranges of `1/N … N/N` are contiguous and cover `0..T` exactly once.
    pub fn range(&self, trials: usize) -> core::ops::Range<usize> {
        let at = |k: usize| ((k as u128 * trials as u128) / self.count as u128) as usize;
        at(self.index - 1)..at(self.index)
    }
}

impl core::fmt::Display for Shard {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

const MAGIC: &[u8; 8] = b"OMKRUNS1";
const HEADER: u64 = 32;

/// Writes a runs file: the header, then [`RunsWriter::push`] every trial of the shard in
/// trial order.
pub struct RunsWriter<W: Write> {
    out: W,
    samples: usize,
    left: usize,
}

impl<W: Write> RunsWriter<W> {
    /// Starts a runs file of `count` trials from trial `first`, `samples` positions each.
    ///
    /// # Errors
    /// Writing the header.
    pub fn new(mut out: W, samples: usize, first: usize, count: usize) -> std::io::Result<Self> {
        out.write_all(MAGIC)?;
        for v in [samples, first, count] {
            out.write_all(&(v as u64).to_le_bytes())?;
        }
        Ok(Self {
            out,
            samples,
            left: count,
        })
    }

    /// Appends the next trial's run (`samples` positions and headings).
    ///
    /// # Errors
    /// `InvalidInput` for a run of another length, without headings, or beyond `count`;
    /// writing.
    pub fn push(&mut self, run: &Run) -> std::io::Result<()> {
        let bad =
            |why: &str| std::io::Error::new(std::io::ErrorKind::InvalidInput, why.to_string());
        let Some(h) = &run.heading else {
            return Err(bad("a run without headings cannot be kept for a merge"));
        };
        if run.xy.len() != self.samples || h.len() != self.samples {
            return Err(bad("a run of another length than the plan's samples"));
        }
        if self.left == 0 {
            return Err(bad("more runs than the runs file was started for"));
        }
        self.left -= 1;
        let mut buf = Vec::with_capacity(24 * self.samples);
        for (p, h) in run.xy.iter().zip(h) {
            for v in [p[0], p[1], *h] {
                buf.extend_from_slice(&v.to_le_bytes());
            }
        }
        self.out.write_all(&buf)
    }

    /// Ends the file: every trial written. Returns the writer.
    ///
    /// # Errors
    /// `InvalidInput` if trials are missing.
    pub fn finish(self) -> std::io::Result<W> {
        if self.left != 0 {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("{} runs missing from the runs file", self.left),
            ));
        }
        Ok(self.out)
    }
}

/// A runs file opened for reading by trial index, from any thread.
pub struct RunsFile {
    path: PathBuf,
    file: Mutex<File>,
    samples: usize,
    first: usize,
    count: usize,
}

impl RunsFile {
    /// Opens `path` and checks that it holds trials `range`, `samples` positions each, and
    /// exactly the bytes that implies.
    ///
    /// # Errors
    /// [`ShardError::Runs`] naming the file and what does not match.
    pub fn open(
        path: &Path,
        samples: usize,
        range: core::ops::Range<usize>,
    ) -> Result<Self, ShardError> {
        let err = |why: String| ShardError::Runs {
            file: path.display().to_string(),
            why,
        };
        let mut file = File::open(path).map_err(|e| err(format!("cannot open: {e}")))?;
        let mut head = [0u8; HEADER as usize];
        file.read_exact(&mut head)
            .map_err(|_| err("too short for a runs file (no header)".into()))?;
        if &head[..8] != MAGIC {
            return Err(err("not a runs file (no OMKRUNS1 header)".into()));
        }
        let word = |k: usize| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&head[8 * k..8 * k + 8]);
            u64::from_le_bytes(b)
        };
        let (s, first, count) = (word(1), word(2), word(3));
        if (s, first, count) != (samples as u64, range.start as u64, range.len() as u64) {
            return Err(err(format!(
                "holds {count} trials from trial {first} of {s} samples each; its shard.json says {} trials from {} of {samples}",
                range.len(),
                range.start
            )));
        }
        let want = (samples as u64)
            .checked_mul(24)
            .and_then(|b| b.checked_mul(count))
            .and_then(|b| b.checked_add(HEADER));
        let len = file
            .metadata()
            .map_err(|e| err(format!("cannot inspect: {e}")))?
            .len();
        if want != Some(len) {
            return Err(err(format!(
                "is {len} bytes, {} expected for {count} trials of {samples} samples (truncated or appended to)",
                want.map_or("more than 2^64".into(), |w| w.to_string())
            )));
        }
        Ok(Self {
            path: path.to_path_buf(),
            file: Mutex::new(file),
            samples,
            first: range.start,
            count: range.len(),
        })
    }

    /// The trials the file holds.
    pub fn range(&self) -> core::ops::Range<usize> {
        self.first..self.first + self.count
    }

    /// Trial `i`'s run (`i` in [`RunsFile::range`]), exactly as written.
    ///
    /// # Errors
    /// [`ShardError::Runs`] for a trial outside the file or a failed read.
    pub fn read(&self, i: usize) -> Result<Run, ShardError> {
        let err = |why: String| ShardError::Runs {
            file: self.path.display().to_string(),
            why,
        };
        if !self.range().contains(&i) {
            return Err(err(format!(
                "has no trial {i} (it holds {}..{})",
                self.first,
                self.first + self.count
            )));
        }
        let bytes = 24 * self.samples;
        let mut buf = vec![0u8; bytes];
        {
            let mut f = self.file.lock().unwrap_or_else(|p| p.into_inner());
            f.seek(SeekFrom::Start(HEADER + ((i - self.first) * bytes) as u64))
                .and_then(|_| f.read_exact(&mut buf))
                .map_err(|e| err(format!("cannot read trial {i}: {e}")))?;
        }
        let mut xy = Vec::with_capacity(self.samples);
        let mut heading = Vec::with_capacity(self.samples);
        for c in buf.chunks_exact(24) {
            let v = |k: usize| {
                let mut b = [0u8; 8];
                b.copy_from_slice(&c[8 * k..8 * k + 8]);
                f64::from_le_bytes(b)
            };
            xy.push([v(0), v(1)]);
            heading.push(v(2));
        }
        Ok(Run {
            xy,
            heading: Some(heading),
        })
    }
}

/// FNV-1a (64 bit) of `bytes`: the fingerprint shards record of their inputs, so a merge
/// can tell that every shard ran the same plan, robot and profile (not a cryptographic hash).
pub fn fingerprint(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn k_of_n_parses_with_rules() {
        assert_eq!(Shard::parse("2/4").unwrap(), Shard { index: 2, count: 4 });
        assert_eq!(Shard::parse(" 1 / 1 ").unwrap().to_string(), "1/1");
        for (bad, says) in [
            ("2", "expected K/N"),
            ("0/4", "K must be between 1 and N = 4"),
            ("5/4", "K must be between 1 and N = 4"),
            ("1/0", "N must be between 1 and"),
            ("a/4", "K must be a whole number"),
            ("1/-2", "N must be a whole number"),
            ("1/20000", "N must be between 1 and 10000"),
        ] {
            let e = Shard::parse(bad).unwrap_err().to_string();
            assert!(e.contains(says), "{bad}: {e}");
        }
        let e = Shard { index: 1, count: 5 }
            .check(4, "--trials")
            .unwrap_err();
        assert!(
            e.to_string()
                .contains("at most the number of trials (--trials)")
        );
    }

    #[test]
    fn shard_ranges_cover_every_trial_once() {
        for trials in [1, 2, 7, 12, 1000, 1001] {
            for count in 1..=trials.min(13) {
                let mut next = 0;
                for index in 1..=count {
                    let r = Shard { index, count }.range(trials);
                    assert_eq!(r.start, next);
                    assert!(!r.is_empty());
                    next = r.end;
                }
                assert_eq!(next, trials);
            }
        }
    }

    #[test]
    fn runs_file_round_trips_bits_and_refuses_a_wrong_one() {
        let dir = std::env::temp_dir().join(format!("omnikin-shard-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("runs.bin");
        let runs: Vec<Run> = (0..3)
            .map(|i| Run {
                xy: vec![[0.1 * i as f64, -0.0], [f64::MIN_POSITIVE, 1e300]],
                heading: Some(vec![std::f64::consts::PI / (i as f64 + 3.0), -1e-310]),
            })
            .collect();
        let mut w = RunsWriter::new(File::create(&path).unwrap(), 2, 5, 3).unwrap();
        for r in &runs {
            w.push(r).unwrap();
        }
        assert!(w.push(&runs[0]).is_err());
        w.finish().unwrap();
        let f = RunsFile::open(&path, 2, 5..8).unwrap();
        for (k, r) in runs.iter().enumerate() {
            let back = f.read(5 + k).unwrap();
            let bits = |r: &Run| {
                r.xy.iter()
                    .flat_map(|p| p.map(f64::to_bits))
                    .chain(r.heading.iter().flatten().map(|h| h.to_bits()))
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(&back), bits(r));
        }
        assert!(
            f.read(8)
                .unwrap_err()
                .to_string()
                .contains("has no trial 8")
        );
        let e = RunsFile::open(&path, 2, 4..7).err().unwrap().to_string();
        assert!(e.contains("holds 3 trials from trial 5"), "{e}");
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
        let e = RunsFile::open(&path, 2, 5..8).err().unwrap().to_string();
        assert!(e.contains("truncated"), "{e}");
        std::fs::write(&path, b"hello").unwrap();
        assert!(RunsFile::open(&path, 2, 5..8).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
