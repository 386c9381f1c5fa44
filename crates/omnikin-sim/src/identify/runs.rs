//! The recorded runs an identification reads: per run an encoder log, a reference trajectory
//! (tracked truth `t,x,y[,heading]` or camera fixes `t,x,y[,heading][,arrival]`) and optionally
//! a gyro (the encoder log's `gyro_z` column, or an IMU log's `gz`), all from the CSV formats of
//! conventions.md as `simulate --emit-sensors` and `robot --log` write them.
//!
//! Errors name the file and line (through [`crate::table::NumericTable`]) and the rule.

use omnikin::{EncoderAngles, MAX_WHEELS};

use crate::table::NumericTable;

use super::IdentifyError;

/// One encoder log: sample times and readings.
#[derive(Clone, Debug, PartialEq)]
pub struct EncoderLog {
    /// The file, as named in messages.
    pub file: String,
    /// Sample times, s (strictly increasing).
    pub t: Vec<f64>,
    /// Cumulative wheel angles and steer angles, rad.
    pub angles: Vec<EncoderAngles<f64>>,
}

/// A yaw-rate record: the encoder log's `gyro_z` column or an IMU log's `gz`.
#[derive(Clone, Debug, PartialEq)]
pub struct GyroLog {
    /// The file (and column), as named in messages.
    pub file: String,
    /// Sample times, s.
    pub t: Vec<f64>,
    /// Measured yaw rate, rad/s.
    pub rate: Vec<f64>,
}

/// The IMU's body rates about the platform's x and y axes (`gx`, `gy` of an IMU log): the
/// sphere's rocking ([`super::rocking`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ImuRates {
    /// The file, as named in messages.
    pub file: String,
    /// Sample times, s.
    pub t: Vec<f64>,
    /// `[gx, gy]` per sample, rad/s (body frame).
    pub rate: Vec<[f64; 2]>,
}

impl ImuRates {
    /// The `gx`, `gy` columns of an IMU log (`t,gx,gy,gz,…`, body frame, rad/s).
    ///
    /// # Errors
    /// [`IdentifyError::Input`] naming the file when a column is missing, and the line and
    /// column of a rate beyond `omnikin_plan::limits::MAX_PLAN_RATE`.
    pub fn from_imu_table(table: &NumericTable) -> Result<Self, IdentifyError> {
        let idx = table
            .require(&["t", "gx", "gy"], "an IMU log (t,gx,gy,gz,…)")
            .map_err(table_error)?;
        bounded(
            table,
            &idx[1..],
            omnikin_plan::limits::MAX_PLAN_RATE,
            "rad/s",
        )?;
        Ok(Self {
            file: table.file.clone(),
            t: table.rows.iter().map(|(_, r)| r[idx[0]]).collect(),
            rate: table
                .rows
                .iter()
                .map(|(_, r)| [r[idx[1]], r[idx[2]]])
                .collect(),
        })
    }
}

/// A reference trajectory: where the robot really was (world frame).
#[derive(Clone, Debug, PartialEq)]
pub struct Reference {
    /// The file, as named in messages.
    pub file: String,
    /// Times, s (for camera fixes the capture time `t`, not the arrival).
    pub t: Vec<f64>,
    /// Positions, m.
    pub xy: Vec<[f64; 2]>,
    /// Headings, rad, when the file has a `heading` column.
    pub heading: Option<Vec<f64>>,
}

/// One run: what the robot's encoders said, where it really was, and its gyro if any.
#[derive(Clone, Debug, PartialEq)]
pub struct LoggedRun {
    /// The encoder log.
    pub encoders: EncoderLog,
    /// The reference trajectory.
    pub reference: Reference,
    /// The gyro, if recorded.
    pub gyro: Option<GyroLog>,
    /// The IMU's x and y body rates, when an IMU log was given.
    pub imu_rates: Option<ImuRates>,
}

fn table_error(e: crate::table::TableError) -> IdentifyError {
    IdentifyError::Input(e.to_string())
}

/// Refuses a finite but meaningless value (1e300 rad) in any of `cols`, at its line and column, with the
/// bound the plan files obey (`omnikin_plan::limits`), as `omnikin odometry` does.
fn bounded(
    table: &NumericTable,
    cols: &[usize],
    max: f64,
    unit: &str,
) -> Result<(), IdentifyError> {
    for (line, row) in &table.rows {
        for &col in cols {
            let v = row[col];
            if v.abs() > max {
                return Err(IdentifyError::Input(format!(
                    "{}:{line}: column {}: {v:e} {unit} is outside the plausible range \
                     [-{max:e}, {max:e}] {unit} (omnikin_plan::limits)",
                    table.file, table.header[col]
                )));
            }
        }
    }
    Ok(())
}

impl EncoderLog {
    /// The encoder log in `table` of a robot with `wheels` wheels (`q1..qN` required, `s1..sN`
    /// too when `steerable`), and its `gyro_z` column if present.
    ///
    /// # Errors
    /// [`IdentifyError::Input`] naming the file and the missing columns, or a file with fewer
    /// than two samples.
    pub fn from_table(
        table: &NumericTable,
        wheels: usize,
        steerable: bool,
    ) -> Result<(Self, Option<GyroLog>), IdentifyError> {
        let wheels = wheels.min(MAX_WHEELS);
        let q_names: Vec<String> = (1..=wheels).map(|i| format!("q{i}")).collect();
        let s_names: Vec<String> = (1..=wheels).map(|i| format!("s{i}")).collect();
        let mut names: Vec<&str> = vec!["t"];
        names.extend(q_names.iter().map(String::as_str));
        if steerable {
            names.extend(s_names.iter().map(String::as_str));
        }
        let idx = table
            .require(&names, "an encoder log of this robot")
            .map_err(table_error)?;
        if table.rows.len() < 2 {
            return Err(IdentifyError::Input(format!(
                "{}: an encoder log needs at least 2 samples (has {})",
                table.file,
                table.rows.len()
            )));
        }
        let gyro_col = table.col("gyro_z");
        let mut log = Self {
            file: table.file.clone(),
            t: Vec::with_capacity(table.rows.len()),
            angles: Vec::with_capacity(table.rows.len()),
        };
        let mut gyro = gyro_col.map(|_| GyroLog {
            file: format!("{} (gyro_z)", table.file),
            t: Vec::new(),
            rate: Vec::new(),
        });
        bounded(table, &idx[1..], omnikin_plan::limits::MAX_HEADING, "rad")?;
        if let Some(c) = gyro_col {
            bounded(table, &[c], omnikin_plan::limits::MAX_PLAN_RATE, "rad/s")?;
        }
        for (_, row) in &table.rows {
            let q: Vec<f64> = (0..wheels).map(|i| row[idx[1 + i]]).collect();
            let s: Vec<f64> = if steerable {
                (0..wheels).map(|i| row[idx[1 + wheels + i]]).collect()
            } else {
                Vec::new()
            };
            log.t.push(row[idx[0]]);
            log.angles.push(EncoderAngles::new(&q, &s));
            if let (Some(g), Some(c)) = (gyro.as_mut(), gyro_col) {
                g.t.push(row[idx[0]]);
                g.rate.push(row[c]);
            }
        }
        Ok((log, gyro))
    }
}

impl LoggedRun {
    /// One run from its tables: the encoder log of a robot with `wheels` wheels (`steerable`:
    /// with `s1..sN`), the reference (fixes or tracked run) and, optionally, an IMU log whose
    /// `gz` replaces the encoder log's `gyro_z` as the gyro (and whose `gx`, `gy` are kept for
    /// the sphere's rocking).
    ///
    /// # Errors
    /// Those of [`EncoderLog::from_table`], [`Reference::from_table`] and
    /// [`GyroLog::from_imu_table`], each naming its file.
    pub fn from_tables(
        encoders: &NumericTable,
        reference: &NumericTable,
        imu: Option<&NumericTable>,
        wheels: usize,
        steerable: bool,
    ) -> Result<Self, IdentifyError> {
        let (encoders, mut gyro) = EncoderLog::from_table(encoders, wheels, steerable)?;
        let mut imu_rates = None;
        if let Some(imu) = imu {
            gyro = Some(GyroLog::from_imu_table(imu)?);
            if imu.col("gx").is_some() && imu.col("gy").is_some() {
                imu_rates = Some(ImuRates::from_imu_table(imu)?);
            }
        }
        Ok(Self {
            encoders,
            reference: Reference::from_table(reference)?,
            gyro,
            imu_rates,
        })
    }
}

impl GyroLog {
    /// The `gz` column of an IMU log (`t,gx,gy,gz,…`, body frame, rad/s).
    ///
    /// # Errors
    /// [`IdentifyError::Input`] naming the file when `gz` is missing.
    pub fn from_imu_table(table: &NumericTable) -> Result<Self, IdentifyError> {
        let idx = table
            .require(&["t", "gz"], "an IMU log (t,gx,gy,gz,…)")
            .map_err(table_error)?;
        bounded(
            table,
            &[idx[1]],
            omnikin_plan::limits::MAX_PLAN_RATE,
            "rad/s",
        )?;
        Ok(Self {
            file: format!("{} (gz)", table.file),
            t: table.rows.iter().map(|(_, r)| r[idx[0]]).collect(),
            rate: table.rows.iter().map(|(_, r)| r[idx[1]]).collect(),
        })
    }
}

impl Reference {
    /// A tracked trajectory or camera fixes: `t,x,y` with an optional `heading` (an `arrival`
    /// column is ignored: the pose belongs to the capture time `t`).
    ///
    /// # Errors
    /// [`IdentifyError::Input`] naming the file when a column is missing or it has fewer than
    /// two rows, and the line and column of a position beyond `omnikin_plan::limits::MAX_COORDINATE`
    /// or a heading beyond `MAX_HEADING`.
    pub fn from_table(table: &NumericTable) -> Result<Self, IdentifyError> {
        let idx = table
            .require(&["t", "x", "y"], "a reference trajectory (t,x,y[,heading])")
            .map_err(table_error)?;
        if table.rows.len() < 2 {
            return Err(IdentifyError::Input(format!(
                "{}: a reference trajectory needs at least 2 rows (has {})",
                table.file,
                table.rows.len()
            )));
        }
        let h = table.col("heading");
        bounded(table, &idx[1..], omnikin_plan::limits::MAX_COORDINATE, "m")?;
        if let Some(c) = h {
            bounded(table, &[c], omnikin_plan::limits::MAX_HEADING, "rad")?;
        }
        Ok(Self {
            file: table.file.clone(),
            t: table.rows.iter().map(|(_, r)| r[idx[0]]).collect(),
            xy: table
                .rows
                .iter()
                .map(|(_, r)| [r[idx[1]], r[idx[2]]])
                .collect(),
            heading: h.map(|c| table.rows.iter().map(|(_, r)| r[c]).collect()),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_encoder_log_with_a_gyro_column() {
        let t = NumericTable::parse("t,q1,q2,q3,gyro_z\n0,0,0,0,0.1\n0.1,1,2,3,0.2\n", "e.csv")
            .unwrap();
        let (log, gyro) = EncoderLog::from_table(&t, 3, false).unwrap();
        assert_eq!(log.t, vec![0.0, 0.1]);
        assert_eq!(&log.angles[1].wheel[..3], &[1.0, 2.0, 3.0]);
        assert_eq!(gyro.unwrap().rate, vec![0.1, 0.2]);
    }

    #[test]
    fn a_missing_wheel_column_names_the_file_and_column() {
        let t = NumericTable::parse("t,q1,q2\n0,0,0\n0.1,1,2\n", "e.csv").unwrap();
        let e = EncoderLog::from_table(&t, 3, false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("e.csv") && e.contains("q3"), "{e}");
    }

    #[test]
    fn a_finite_but_meaningless_angle_or_rate_names_its_line_and_column() {
        for (text, col) in [
            (
                "t,q1,q2,q3,gyro_z\n0,0,0,0,0.1\n0.1,1e300,2,3,0.2\n",
                "column q1",
            ),
            (
                "t,q1,q2,q3,gyro_z\n0,0,0,0,0.1\n0.1,1,2,3,-1e300\n",
                "column gyro_z",
            ),
        ] {
            let t = NumericTable::parse(text, "e.csv").unwrap();
            let e = EncoderLog::from_table(&t, 3, false)
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("e.csv:3: ") && e.contains(col), "{e}");
            assert!(e.contains("plausible range"), "{e}");
        }
        let t = NumericTable::parse("t,x,y,heading\n0,0,0,0\n0.1,0,1e300,0\n", "f.csv").unwrap();
        let e = Reference::from_table(&t).unwrap_err().to_string();
        assert!(e.starts_with("f.csv:3: column y"), "{e}");
        let t = NumericTable::parse("t,gx,gy,gz\n0,0,0,1e300\n", "imu.csv").unwrap();
        let e = GyroLog::from_imu_table(&t).unwrap_err().to_string();
        assert!(e.starts_with("imu.csv:2: column gz"), "{e}");
    }

    #[test]
    fn fixes_keep_the_capture_time() {
        let t = NumericTable::parse("t,x,y,arrival\n0,1,2,0.1\n0.1,1.5,2,0.2\n", "f.csv").unwrap();
        let r = Reference::from_table(&t).unwrap();
        assert_eq!(r.t, vec![0.0, 0.1]);
        assert_eq!(r.xy[1], [1.5, 2.0]);
        assert!(r.heading.is_none());
    }
}
