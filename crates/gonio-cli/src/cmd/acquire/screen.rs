//! The operator's full-screen view (ratatui): where the plan stands, what to set next, the live
//! X, the last reading's spread, the closure and drift checks, and the keys.

use super::{Args, End, check_line, read_line};
use anyhow::Result;
use gonio_lab::acquire::{AcquireError, Acquisition, Attempt, Check, CheckKind};
use gonio_lab::instrument::{Autocollimator, Transport};
use gonio_lab::journal::{ExchangeKind, Record};
use gonio_lab::log::Reply;
use gonio_lab::sequence::Sequence;
use ratatui::crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
use ratatui::layout::{Constraint, Layout};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Gauge, Paragraph};
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// How often the live X is read while the operator sets the polygon.
const LIVE_EVERY: Duration = Duration::from_millis(700);

/// A decision the operator owes.
enum Ask {
    /// The spread stayed over the limit: read again, accept, skip, quit.
    Spread {
        index: usize,
        spread_arcsec: f64,
        record: Record,
    },
    /// The instrument answered with no reading: read again, skip, quit.
    Fault {
        index: usize,
        reason: String,
        exchanges: Vec<(ExchangeKind, Vec<u8>)>,
    },
}

struct View {
    port: String,
    plan: String,
    live: Option<String>,
    last: Option<String>,
    /// The last checks (what they are of is on the messages' lines).
    closure: Option<Check<()>>,
    drift: Option<Check<()>>,
    worst_drift: f64,
    messages: VecDeque<String>,
    paused: bool,
    ask: Option<Ask>,
}

impl View {
    fn say(&mut self, m: String) {
        if self.messages.len() == 6 {
            self.messages.pop_front();
        }
        self.messages.push_back(m);
    }
}

/// Restores the terminal however the view ends.
struct Restore;

impl Drop for Restore {
    fn drop(&mut self) {
        ratatui::restore();
    }
}

/// Runs the view until the plan is complete or the operator quits.
pub(super) fn run<S: Sequence, T: Transport>(
    acq: &mut Acquisition<S>,
    port: &mut Autocollimator<T>,
    args: &Args,
) -> Result<End> {
    let mut terminal =
        ratatui::try_init().map_err(|e| anyhow::anyhow!("cannot set up the terminal: {e}"))?;
    let _restore = Restore;
    let mut v = View {
        port: args.port.clone(),
        plan: args.plan.display().to_string(),
        live: None,
        last: None,
        closure: None,
        drift: None,
        worst_drift: 0.0,
        messages: VecDeque::new(),
        paused: false,
        ask: None,
    };
    if acq.done() > 0 {
        v.say(format!("resumed: {} positions done", acq.done()));
    }
    let mut next_live = Instant::now();
    loop {
        let Some(next) = acq.next() else {
            return Ok(End::Complete);
        };
        terminal
            .draw(|f| draw(f, acq, &v, next))
            .map_err(|e| anyhow::anyhow!("cannot draw on the terminal: {e}"))?;
        if event::poll(Duration::from_millis(100))
            .map_err(|e| anyhow::anyhow!("cannot read the keyboard: {e}"))?
        {
            let Event::Key(k) =
                event::read().map_err(|e| anyhow::anyhow!("cannot read the keyboard: {e}"))?
            else {
                continue;
            };
            if k.kind != KeyEventKind::Press {
                continue;
            }
            let ctrl_c =
                k.code == KeyCode::Char('c') && k.modifiers.contains(KeyModifiers::CONTROL);
            if k.code == KeyCode::Char('q') || ctrl_c {
                return Ok(End::Quit);
            }
            if let Some(ask) = v.ask.take() {
                answer(acq, port, &mut v, ask, k.code)?;
                continue;
            }
            match k.code {
                KeyCode::Char('p') => {
                    v.paused = !v.paused;
                    v.say(if v.paused {
                        "paused".into()
                    } else {
                        "resumed".into()
                    });
                }
                _ if v.paused => v.say("paused: p resumes".into()),
                KeyCode::Enter | KeyCode::Char('r') => measure(acq, port, &mut v, next)?,
                KeyCode::Char('e') => match acq.last() {
                    Some(l) => measure(acq, port, &mut v, l)?,
                    None => v.say("nothing read yet to read again".into()),
                },
                KeyCode::Char('s') => {
                    acq.skip(next, Vec::new())?;
                    v.say(format!(
                        "skipped {}",
                        acq.plan().fields(&acq.planned()[next])
                    ));
                }
                _ => {}
            }
        } else if !v.paused && v.ask.is_none() && Instant::now() >= next_live {
            // The live X, for the operator to see the image settle: not a reading.
            let e = port.read(acq.settings().mode).map_err(AcquireError::from)?;
            v.live = Some(match e.reply {
                Reply::Reading {
                    x_arcsec,
                    x_decimals,
                    ..
                } => {
                    format!("{:+.d$}″", acq.plan().x_sign() * x_arcsec, d = x_decimals)
                }
                Reply::Flagged { code } => format!("flagged (status {code})"),
                Reply::Garbage { .. } => "garbage on the line".into(),
            });
            next_live = Instant::now() + LIVE_EVERY;
        }
    }
}

fn measure<S: Sequence, T: Transport>(
    acq: &mut Acquisition<S>,
    port: &mut Autocollimator<T>,
    v: &mut View,
    index: usize,
) -> Result<()> {
    match acq.measure(port, index)? {
        Attempt::Accepted(record) => accept(acq, v, record),
        Attempt::SpreadOver {
            spread_arcsec,
            record,
        } => {
            v.say(format!(
                "spread {spread_arcsec:.4}″ over the limit {}″ after {} re-reads",
                acq.settings().max_spread_arcsec,
                acq.settings().rereads
            ));
            v.ask = Some(Ask::Spread {
                index,
                spread_arcsec,
                record,
            });
            Ok(())
        }
        Attempt::Faulty { reason, exchanges } => {
            v.say(format!("no reading: {}", gonio_core::text::short(&reason)));
            v.ask = Some(Ask::Fault {
                index,
                reason,
                exchanges,
            });
            Ok(())
        }
    }
}

fn accept<S: Sequence>(acq: &mut Acquisition<S>, v: &mut View, record: Record) -> Result<()> {
    let index = record.index;
    acq.commit(record)?;
    v.last = read_line(acq, index);
    for c in acq.checks(index) {
        if !c.ok() {
            v.say(check_line(acq.plan(), &c));
        }
        let c = Check {
            kind: c.kind,
            value_arcsec: c.value_arcsec,
            limit_arcsec: c.limit_arcsec,
            reading: (),
        };
        match c.kind {
            CheckKind::Closure => v.closure = Some(c),
            CheckKind::Drift => {
                v.worst_drift = v.worst_drift.max(c.value_arcsec.abs());
                v.drift = Some(c);
            }
        }
    }
    Ok(())
}

fn answer<S: Sequence, T: Transport>(
    acq: &mut Acquisition<S>,
    port: &mut Autocollimator<T>,
    v: &mut View,
    ask: Ask,
    key: KeyCode,
) -> Result<()> {
    let index = match &ask {
        Ask::Spread { index, .. } | Ask::Fault { index, .. } => *index,
    };
    match (key, ask) {
        (KeyCode::Enter | KeyCode::Char('r'), _) => measure(acq, port, v, index),
        (KeyCode::Char('a'), Ask::Spread { record, .. }) => {
            v.say("accepted over the spread limit".into());
            accept(acq, v, record)
        }
        (KeyCode::Char('s'), Ask::Spread { record, .. }) => {
            acq.skip(index, record.exchanges)?;
            v.say(format!(
                "skipped {}",
                acq.plan().fields(&acq.planned()[index])
            ));
            Ok(())
        }
        (KeyCode::Char('s'), Ask::Fault { exchanges, .. }) => {
            acq.skip(index, exchanges)?;
            v.say(format!(
                "skipped {}",
                acq.plan().fields(&acq.planned()[index])
            ));
            Ok(())
        }
        (_, ask) => {
            // Not an answer: the question stays.
            v.ask = Some(ask);
            Ok(())
        }
    }
}

fn check_text(c: Option<&Check<()>>) -> Span<'static> {
    match c {
        None => Span::raw("—"),
        Some(c) => Span::styled(
            format!(
                "{:+.4}″ (limit ±{:.4}″) {}",
                c.value_arcsec,
                c.limit_arcsec,
                if c.ok() { "ok" } else { "OVER" }
            ),
            Style::default().fg(if c.ok() { Color::Green } else { Color::Red }),
        ),
    }
}

fn draw<S: Sequence>(f: &mut ratatui::Frame<'_>, acq: &Acquisition<S>, v: &View, next: usize) {
    let plan = acq.plan();
    let p = acq.planned()[next];
    let total = acq.planned().len();
    let [top, gauge, set, inst, log, keys] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Length(1),
        Constraint::Length(4),
        Constraint::Length(7),
        Constraint::Min(3),
        Constraint::Length(1),
    ])
    .areas(f.area());
    f.render_widget(
        Paragraph::new(format!(
            "gonio acquire {} — {} — {} — position {} of {total} ({} done, {} skipped)",
            plan.command(),
            v.port,
            v.plan,
            next + 1,
            acq.done(),
            acq.missing()
        ))
        .style(Style::default().add_modifier(Modifier::BOLD)),
        top,
    );
    f.render_widget(
        Gauge::default()
            .ratio(acq.done() as f64 / total.max(1) as f64)
            .gauge_style(Style::default().fg(Color::Cyan)),
        gauge,
    );
    f.render_widget(
        Paragraph::new(vec![
            Line::from(Span::styled(
                plan.instruction(&p),
                Style::default().add_modifier(Modifier::BOLD),
            )),
            Line::from(format!("({})", plan.fields(&p))),
        ])
        .block(Block::default().borders(Borders::ALL).title(" Next ")),
        set,
    );
    let s = acq.settings();
    f.render_widget(
        Paragraph::new(vec![
            Line::from(format!(
                "live X  {}{}",
                v.live.as_deref().unwrap_or("—"),
                if v.paused { "   (paused)" } else { "" }
            )),
            Line::from(format!("last    {}", v.last.as_deref().unwrap_or("—"))),
            Line::from(format!(
                "samples {} a position, spread limit {}″, σ {}″",
                s.samples, s.max_spread_arcsec, s.sigma_arcsec
            )),
            Line::from(vec![Span::raw("closure "), check_text(v.closure.as_ref())]),
            Line::from(vec![
                Span::raw("drift   "),
                check_text(v.drift.as_ref()),
                Span::raw(format!("   largest so far {:.4}″", v.worst_drift)),
            ]),
        ])
        .block(
            Block::default()
                .borders(Borders::ALL)
                .title(" Autocollimator "),
        ),
        inst,
    );
    let mut lines: Vec<Line> = v.messages.iter().map(|m| Line::from(m.clone())).collect();
    if let Some(ask) = &v.ask {
        lines.push(Line::from(Span::styled(
            match ask {
                Ask::Spread { spread_arcsec, .. } => format!(
                    "spread {spread_arcsec:.4}″ over the limit: Enter reads again, a accepts, s skips, q quits"
                ),
                Ask::Fault { reason, .. } => format!(
                    "no reading ({}): Enter reads again, s skips, q quits",
                    gonio_core::text::short(reason)
                ),
            },
            Style::default().fg(Color::Yellow),
        )));
    }
    f.render_widget(
        Paragraph::new(lines).block(Block::default().borders(Borders::ALL).title(" Messages ")),
        log,
    );
    f.render_widget(
        Paragraph::new(
            "Enter/r read · e re-read last · s skip · p pause · q quit (readings are kept)",
        ),
        keys,
    );
}
