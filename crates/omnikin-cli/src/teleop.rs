//! Keyboard teleoperation for `omnikin drive teleop` (crossterm raw mode).
//!
//! Keys set the commanded robot-frame velocity while they are held (terminal auto-repeat);
//! with no key for 0.3 s the command falls back to zero (dead-man behaviour), so a dropped
//! keyboard or a closed terminal never leaves the robot running — and the robot's own watchdog
//! stops it if this process dies.

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
use crossterm::terminal;
use omnikin::link::{Message, Telemetry};
use omnikin::runtime::Frame;

/// Restores the terminal on every exit path.
struct Raw;
impl Drop for Raw {
    fn drop(&mut self) {
        let _ = terminal::disable_raw_mode();
    }
}

/// The operator's side of the link, as teleop needs it.
pub trait Operator {
    /// Sends one message.
    fn send(&mut self, m: &Message) -> Result<()>;
    /// Receives for `d` and returns the newest telemetry.
    fn poll(&mut self, d: Duration) -> Result<Option<Telemetry>>;
}

/// Runs the teleop loop until Esc or Ctrl-C; `period` is the command repeat period.
pub fn run(op: &mut dyn Operator, speed: f64, turn: f64, period: Duration) -> Result<()> {
    if !std::io::stdin().is_terminal() {
        bail!("teleop needs an interactive terminal (stdin is not a TTY)");
    }
    terminal::enable_raw_mode()?;
    let _raw = Raw;
    let mut out = std::io::stdout();
    write!(
        out,
        "teleop: w/s forward/back, a/d left/right, q/e turn, space stop, x e-stop, c clear, Esc quit\r\n"
    )?;
    let (mut vx, mut vy, mut wz) = (0.0f64, 0.0f64, 0.0f64);
    let mut last_key = Instant::now() - Duration::from_secs(1);
    loop {
        while event::poll(Duration::ZERO)? {
            if let Event::Key(k) = event::read()? {
                if k.kind == KeyEventKind::Release {
                    continue;
                }
                last_key = Instant::now();
                (vx, vy, wz) = (0.0, 0.0, 0.0);
                match k.code {
                    KeyCode::Char('c') | KeyCode::Char('C')
                        if k.modifiers.contains(KeyModifiers::CONTROL) =>
                    {
                        op.send(&Message::Stop)?;
                        return Ok(());
                    }
                    KeyCode::Char('w') => vx = speed,
                    KeyCode::Char('s') => vx = -speed,
                    KeyCode::Char('a') => vy = speed,
                    KeyCode::Char('d') => vy = -speed,
                    KeyCode::Char('q') => wz = turn,
                    KeyCode::Char('e') => wz = -turn,
                    KeyCode::Char('x') => op.send(&Message::EStop)?,
                    KeyCode::Char('c') => op.send(&Message::Clear)?,
                    KeyCode::Char(' ') => op.send(&Message::Stop)?,
                    KeyCode::Esc => {
                        op.send(&Message::Stop)?;
                        write!(out, "\r\nstopped\r\n")?;
                        return Ok(());
                    }
                    _ => {}
                }
            }
        }
        if last_key.elapsed() < Duration::from_millis(300) && (vx != 0.0 || vy != 0.0 || wz != 0.0)
        {
            op.send(&Message::SetVelocity {
                frame: Frame::Robot,
                vx: vx as f32,
                vy: vy as f32,
                yaw_rate: wz as f32,
            })?;
        } else {
            if vx != 0.0 || vy != 0.0 || wz != 0.0 {
                op.send(&Message::Stop)?;
                (vx, vy, wz) = (0.0, 0.0, 0.0);
            }
            op.send(&Message::Heartbeat)?;
        }
        if let Some(t) = op.poll(period)? {
            write!(
                out,
                "\r{:>9.2} s  {:<10} x {:>8.3} y {:>8.3} heading {:>7.3}  faults {:<20}",
                t.time_us as f64 * 1e-6,
                t.mode.name(),
                t.pose[0],
                t.pose[1],
                t.pose[2],
                t.faults.to_string()
            )?;
            out.flush()?;
        }
    }
}
