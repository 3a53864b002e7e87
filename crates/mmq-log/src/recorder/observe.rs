//! What the recorder writes for each observer hook: the run's start (metadata,
//! attachments, scenes, the first pose), each step (decision, motion, rewards, teleport),
//! the heat maps, and the end.

use std::collections::BTreeMap;

use mmq_core::{Emission, Event, Move, Observer, PoseSample, Resume, RunInfo, State, StepGate, StepRecord};

use super::scenes::{ESTIMATE_FRAME, arena_scene, estimate_scene, heatmap, robot_radius, robot_scene};
use super::{CHUNK_SIZE, Ch, McapRecorder, RecorderConfig, Run, ns};
use crate::messages as m;

impl Observer for McapRecorder {
    fn trace_period_s(&self) -> Option<f64> {
        Some(self.config.trace_period_s())
    }

    fn error(&self) -> Option<String> {
        self.error.as_ref().map(ToString::to_string)
    }

    /// A live-only recorder wants the steps only while a client is connected (a file
    /// keeps every step: no gate).
    fn step_gate(&self) -> Option<StepGate> {
        if self.file { None } else { self.live.as_ref().map(|l| l.gate()) }
    }

    /// A step's messages need only its own emission and deliveries from the ledger.
    fn ledger_history(&self) -> bool {
        false
    }

    /// Picks up the running figures the skipped steps would have kept: the step count,
    /// the reward totals and the next emission's id, the step's start time.
    fn on_resume(&mut self, at: &Resume) {
        let Some(run) = &self.run else { return };
        if self.file {
            return;
        }
        self.stats.steps_seen = at.t;
        self.emitted_total = at.emitted_total;
        self.delivered_total = at.delivered_total;
        self.next_emission_id = at.emissions;
        if run.grid {
            self.step_start_s = (at.t * self.period_ns) as f64 * 1e-9;
        } else {
            let now_s = at.sim_time_s + self.time_offset_s;
            if now_s + 1e-9 < self.step_start_s {
                self.time_offset_s = self.step_start_s;
            }
            self.step_start_s = at.sim_time_s + self.time_offset_s;
            // As while skipping: the thinning clock does not lag behind.
            self.next_pose_s = self.next_pose_s.max(self.step_start_s);
        }
        self.prev_recorded = false;
    }

    fn on_start(&mut self, info: &RunInfo<'_>, initial_state: State, sim_time_s: f64) {
        let world = info.world.clone();
        let grid = info.env_kind == "grid";
        let fact_period = info
            .facts
            .iter()
            .find(|(k, _)| k == "grid_step_period_s")
            .and_then(|(_, v)| v.parse::<f64>().ok())
            .filter(|p| p.is_finite() && *p > 0.0)
            .map(ns);
        self.period_ns = self
            .config
            .step_period_ns
            .or(fact_period)
            .unwrap_or(RecorderConfig::DEFAULT_STEP_PERIOD_NS)
            .max(1);
        let start_ns = if grid { 0 } else { ns(sim_time_s) };
        self.step_start_s = sim_time_s;
        // The start pose is written below; the trace's samples follow one period later.
        self.next_pose_s =
            sim_time_s + if self.config.pose_rate_hz > 0.0 { 1.0 / self.config.pose_rate_hz } else { 0.0 };
        let radius = robot_radius(info);
        let ts = m::Time::from_ns(start_ns);
        let arena_json = serde_json::to_vec(&arena_scene(&world, ts)).expect("JSON of a scene");
        let robot_json = serde_json::to_vec(&robot_scene(radius, ts)).expect("JSON of a scene");
        let estimate_json = serde_json::to_vec(&estimate_scene(radius, ts)).expect("JSON of a scene");
        let config = &self.config;
        let mut run: BTreeMap<String, String> = BTreeMap::new();
        let mut put = |k: &str, v: String| {
            run.insert(k.to_string(), v);
        };
        put("seed", info.seed.to_string());
        put("learner", info.learner.to_string());
        put("env_kind", info.env_kind.to_string());
        put("world", world.name.clone());
        put("world_size", format!("{}x{}", world.width, world.height));
        put("cell_size_m", world.cell_size.to_string());
        put("actions", info.action_names.join(","));
        put("initial_state", initial_state.to_string());
        put("mmq_log_version", env!("CARGO_PKG_VERSION").to_string());
        put("mcap_library", mcap::LIBRARY_IDENTIFIER.to_string());
        for (k, v) in info.facts {
            put(k, v.clone());
        }
        let recorder: BTreeMap<String, String> = [
            ("time_base", "log_time = simulated ns since run start".to_string()),
            ("step_period_ns", if grid { self.period_ns.to_string() } else { "n/a (robot clock)".into() }),
            ("pose_rate_hz", config.pose_rate_hz.to_string()),
            (
                "window",
                config.window.map_or("all".into(), |w| {
                    format!("first {} and last {} of {}", w.first, w.last, w.total)
                }),
            ),
            ("flush_every_steps", config.flush_every_steps.to_string()),
            (
                "compression",
                format!("zstd level {}, chunks of {} KiB", config.compression_level, CHUNK_SIZE >> 10),
            ),
            ("robot_radius_m", radius.to_string()),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
        if let Some(w) = self.writer.as_mut() {
            let r = w
                .metadata("run", &run)
                .and_then(|()| w.metadata("recorder", &recorder))
                .and_then(|()| w.attach("world.toml", "application/toml", start_ns, world.source.as_bytes()))
                .and_then(|()| {
                    w.attach("config.toml", "application/toml", start_ns, info.config_toml.as_bytes())
                });
            if let Err(e) = r {
                self.fail(e);
            }
        }
        self.run = Some(Run {
            world,
            grid,
            action_names: info.action_names.to_vec(),
            arena_json,
            robot_json,
            estimate_json,
            estimates_seen: false,
        });
        self.write_scenes(start_ns);
        // The first pose: the robot's own (its true heading), else the start cell's centre.
        match info.start_pose.filter(|p| !grid && p.x.is_finite() && p.y.is_finite() && p.theta.is_finite()) {
            Some(p) => {
                self.heading = p.theta;
                self.write_pose(start_ns, p.x, p.y, p.theta);
            }
            None => {
                self.heading = 0.0;
                if grid || initial_state < info.world.num_cells() {
                    self.write_cell_pose(start_ns, initial_state);
                }
            }
        }
        self.prev_recorded = true;
        self.note(
            start_ns,
            m::LOG_INFO,
            format!(
                "run start: {} on {} ({}), seed {}, initial state {initial_state}",
                info.learner, info.world.name, info.env_kind, info.seed
            ),
        );
    }

    fn on_step(&mut self, rec: &StepRecord<'_>) {
        if !self.skip_quiet_step(rec) {
            self.step(rec);
        }
    }

    fn on_tables(&mut self, t: u64, sim_time_s: f64, visits: &[f64], values: &[f64]) {
        if !self.config.heatmaps {
            return;
        }
        let Some(run) = &self.run else { return };
        let log_time = if run.grid { t * self.period_ns } else { ns(sim_time_s + self.time_offset_s) };
        let n = run.world.num_cells();
        if visits.len() != n || values.len() != n {
            let msg = format!(
                "heat maps skipped at step {t}: {} visit and {} value entries for {n} cells",
                visits.len(),
                values.len()
            );
            self.note(log_time, m::LOG_WARNING, msg);
            return;
        }
        let visits = heatmap(&run.world, log_time, "visits", visits);
        let value = heatmap(&run.world, log_time, "value", values);
        self.write(Ch::Visits, log_time, &visits);
        self.write(Ch::Value, log_time, &value);
    }

    fn on_finish(&mut self, t: u64, complete: bool) {
        if !self.file {
            // Steps skipped behind the gate at the end were seen all the same.
            self.stats.steps_seen = self.stats.steps_seen.max(t);
        }
        if let Err(e) = self.finish(t, complete) {
            self.error = Some(e);
        }
    }
}

impl McapRecorder {
    /// Everything a step writes; see the module documentation.
    #[inline(never)]
    fn step(&mut self, rec: &StepRecord<'_>) {
        let Some(run) = &self.run else { return };
        let grid = run.grid;
        let t = rec.t;
        let period = self.period_ns;
        // Step times (robot: keep the clock monotonic even if the environment resets it).
        let mut end_s = rec.sim_time_s + self.time_offset_s;
        if !grid && end_s + 1e-9 < self.step_start_s {
            self.time_offset_s = self.step_start_s;
            end_s = rec.sim_time_s + self.time_offset_s;
        }
        let (start_ns, end_ns) =
            if grid { (t * period, (t + 1) * period) } else { (ns(self.step_start_s), ns(end_s)) };
        // Running figures are kept over every step, recorded or not.
        let emission = (rec.emitted != 0.0).then(|| {
            let (id, delay, times) = match rec.emission() {
                Some(e) => (e.id, e.delay, Some((e.t_emit_s, e.drawn_s))),
                None => (self.next_emission_id, rec.delay.unwrap_or(0), None),
            };
            self.next_emission_id = id + 1;
            self.emitted_total += rec.emitted;
            // A delay in seconds has no steps yet (they are known at delivery).
            let delay = (delay != Emission::PENDING).then_some(delay);
            let t_emit_s = times.map_or(rec.sim_time_s, |(t, _)| t);
            let drawn_s = times.map(|(_, d)| d).filter(|d| d.is_finite());
            (id, delay, t_emit_s, drawn_s)
        });
        self.delivered_total += rec.delivered;
        let recorded = self.config.window.is_none_or(|w| w.contains(t)) && self.active();
        self.stats.steps_seen += 1;
        if recorded {
            self.stats.steps_recorded += 1;
            if (grid || rec.trace.poses.is_empty()) && !self.prev_recorded {
                // Entering a window: show where the decision is taken.
                self.write_cell_pose(start_ns, rec.state);
            }
            // Messages are built only where they go (a live view thins what it sends).
            self.write_with(Ch::Decision, start_ns, |r| m::Decision {
                t,
                state: rec.state as u64,
                action: rec.action as u64,
                action_name: r
                    .run
                    .as_ref()
                    .and_then(|run| run.action_names.get(rec.action).cloned())
                    .unwrap_or_else(|| rec.action.to_string()),
                model: rec.model.map(|x| x as u64),
                explored: rec.explored,
                next_state: rec.next_state as u64,
                event: rec.event.name().to_string(),
            });
            self.write_motion(rec, grid, end_ns);
            if let Some((id, delay, t_emit_s, drawn_s)) = emission {
                let cause = match rec.event {
                    Event::WallBump => "wall",
                    Event::Teleport => "goal",
                    Event::Moved | Event::TimedOut => "step",
                };
                self.write_with(Ch::Emitted, end_ns, |r| m::RewardEmitted {
                    id,
                    t,
                    value: rec.emitted,
                    cause: cause.into(),
                    delay,
                    due: delay.map(|d| t + u64::from(d)),
                    t_emit_s: Some(t_emit_s).filter(|x| x.is_finite()),
                    delay_s: drawn_s,
                    due_s: drawn_s.map(|d| t_emit_s + d),
                    total: r.emitted_total,
                });
            }
            if rec.delivered != 0.0 || !rec.delivered_ids.is_empty() {
                self.write_with(Ch::Delivered, end_ns, |r| {
                    let parts = rec
                        .ledger
                        .map(|l| {
                            rec.delivered_ids
                                .iter()
                                .filter_map(|&id| l.get(id))
                                .map(|e| m::DeliveredPart {
                                    id: e.id,
                                    t_emit: e.t_emit,
                                    delay: e.delay,
                                    value: e.value,
                                    t_emit_s: Some(e.t_emit_s).filter(|x| x.is_finite()),
                                    delay_s: Some(e.delay_s()).filter(|x| x.is_finite()),
                                    drawn_s: Some(e.drawn_s).filter(|x| x.is_finite()),
                                })
                                .collect()
                        })
                        .unwrap_or_default();
                    m::RewardDelivered {
                        t,
                        sum: rec.delivered,
                        ids: rec.delivered_ids.to_vec(),
                        parts,
                        total: r.delivered_total,
                    }
                });
            }
            if rec.event == Event::Teleport {
                self.write_with(Ch::Teleport, end_ns, |r| {
                    let center = |s: State| {
                        let w = &r.run.as_ref().expect("run started").world;
                        let (x, y) = if s < w.num_cells() { w.cell_center(s) } else { (f64::NAN, f64::NAN) };
                        m::Point2 { x, y }
                    };
                    m::Teleport {
                        t,
                        from_state: rec.state as u64,
                        to_state: rec.next_state as u64,
                        from: center(rec.state),
                        to: center(rec.next_state),
                    }
                });
            }
        } else if let Some(p) = rec.trace.poses.last() {
            // Keep the thinning clock moving while skipping.
            self.next_pose_s = self.next_pose_s.max(p.time_s + self.time_offset_s);
        }
        self.prev_recorded = recorded;
        if let Some(live) = self.live.as_mut().filter(|_| recorded) {
            live.step_end(end_ns);
        }
        self.step_start_s = if grid { ((t + 1) * period) as f64 * 1e-9 } else { end_s };
        self.maybe_flush();
    }

    /// A live-only grid step (no file) of which the live view would send nothing now
    /// but the latched scenes ([`crate::live::LiveTap::quiet`]: its decision, emission,
    /// delivery, teleport, pose and time update all fall within the thinning's gap; no
    /// contact; inside the window, a client connected): keeps the running figures
    /// exactly as the full path would, paces, and returns `true`. Else returns `false`
    /// and does nothing. An unpaced watched run skips nearly every step this way (the
    /// messages that do go out are some 30 a second).
    fn skip_quiet_step(&mut self, rec: &StepRecord<'_>) -> bool {
        const D: usize = Ch::Decision as usize;
        const E: usize = Ch::Emitted as usize;
        const R: usize = Ch::Delivered as usize;
        const T: usize = Ch::Teleport as usize;
        let Some(live) = self.live.as_ref() else { return false };
        let emitted = rec.emitted != 0.0;
        let delivered = rec.delivered != 0.0 || !rec.delivered_ids.is_empty();
        let teleport = rec.event == Event::Teleport;
        let slots: &[usize] = match (emitted, delivered, teleport) {
            (false, false, false) => &[D],
            (true, false, false) => &[D, E],
            (false, true, false) => &[D, R],
            (true, true, false) => &[D, E, R],
            (false, false, true) => &[D, T],
            (true, false, true) => &[D, E, T],
            (false, true, true) => &[D, R, T],
            (true, true, true) => &[D, E, R, T],
        };
        // The clock first: it fails only when something is due (some 30 times a second).
        if !live.quiet(slots)
            || self.file
            || !self.prev_recorded
            || !rec.trace.contacts.is_empty()
            || !live.has_clients()
            || !self.run.as_ref().is_some_and(|r| r.grid)
            || !self.config.window.is_none_or(|w| w.contains(rec.t))
        {
            return false;
        }
        // What `on_step` keeps over every step.
        if emitted {
            let id = rec.emission().map_or(self.next_emission_id, |e| e.id);
            self.next_emission_id = id + 1;
            self.emitted_total += rec.emitted;
        }
        self.delivered_total += rec.delivered;
        self.stats.steps_seen += 1;
        self.stats.steps_recorded += 1;
        // What `write_motion` and `write_pose` keep for a pose held back.
        if let Some(h) = move_heading(rec.action) {
            self.heading = h;
        }
        let end_ns = (rec.t + 1) * self.period_ns;
        if teleport {
            self.heading = 0.0;
        }
        if self.run.as_ref().is_some_and(|r| rec.next_state < r.world.num_cells()) {
            self.topics[Ch::Tf as usize].count += 1;
            self.topics[Ch::Pose as usize].count += 1;
        }
        self.live_pose = false;
        if let Some(live) = self.live.as_mut() {
            live.pace_step(end_ns);
        }
        self.step_start_s = end_ns as f64 * 1e-9;
        true
    }

    /// Poses and contacts of a step, in time order.
    fn write_motion(&mut self, rec: &StepRecord<'_>, grid: bool, end_ns: u64) {
        let trace = rec.trace;
        if grid || trace.poses.is_empty() {
            if let Some(h) = move_heading(rec.action).filter(|_| grid) {
                self.heading = h;
            }
            if rec.event == Event::Teleport {
                self.heading = 0.0;
            }
            for c in &trace.contacts {
                self.write_contact(rec.t, c);
            }
            self.write_cell_pose(end_ns, rec.next_state);
            return;
        }
        let period = if self.config.pose_rate_hz > 0.0 { 1.0 / self.config.pose_rate_hz } else { 0.0 };
        let off = self.time_offset_s;
        let mut contacts = trace.contacts.iter().peekable();
        let mut fixes = trace.fixes.iter().peekable();
        let last = trace.poses.len() - 1;
        for (i, p) in trace.poses.iter().enumerate() {
            let time = p.time_s + off;
            while let Some(c) = contacts.next_if(|c| c.time_s + off <= time) {
                self.write_contact(rec.t, c);
            }
            while let Some(f) = fixes.next_if(|f| f.time_s + off <= time) {
                self.write_fix(f);
            }
            // The step's last sample (its end pose, after a teleport too) is always kept.
            if period == 0.0 || time + 1e-9 >= self.next_pose_s || i == last {
                self.write_pose(ns(time), p.x, p.y, p.theta);
                // The estimate is sampled at the same times as the true pose.
                if let Some(e) = trace.estimates.get(i) {
                    self.write_estimate(e);
                }
                if period > 0.0 {
                    self.next_pose_s = ((time / period + 1e-9).floor() + 1.0) * period;
                }
            }
        }
        for c in contacts {
            self.write_contact(rec.t, c);
        }
        for f in fixes {
            self.write_fix(f);
        }
    }

    /// The robot's pose estimate: `/tf` world → robot_estimate and `/robot/pose_estimate`;
    /// the first one also brings the estimate's body (`/viz/robot_estimate`).
    fn write_estimate(&mut self, e: &PoseSample) {
        let time_ns = ns(e.time_s + self.time_offset_s);
        let first = self.run.as_mut().is_some_and(|r| !std::mem::replace(&mut r.estimates_seen, true));
        if first {
            let bytes = self.run.as_ref().map(|r| r.estimate_json.clone()).unwrap_or_default();
            self.write_bytes(Ch::RobotEstimate, time_ns, &bytes);
        }
        let ts = m::Time::from_ns(time_ns);
        self.write_with(Ch::Tf, time_ns, |_| m::FrameTransform {
            timestamp: ts,
            parent_frame_id: "world".into(),
            child_frame_id: ESTIMATE_FRAME.into(),
            translation: m::Vector3 { x: e.x, y: e.y, z: 0.0 },
            rotation: m::Quaternion::yaw(e.theta),
        });
        self.write_with(Ch::PoseEstimate, time_ns, |_| m::PoseInFrame {
            timestamp: ts,
            frame_id: "world".into(),
            pose: m::Pose::planar(e.x, e.y, 0.0, e.theta),
        });
    }

    /// A localisation fix on `/robot/fix`, at the time it was received.
    fn write_fix(&mut self, f: &PoseSample) {
        let time_ns = ns(f.time_s + self.time_offset_s);
        let ts = m::Time::from_ns(time_ns);
        self.write_with(Ch::Fix, time_ns, |_| m::PoseInFrame {
            timestamp: ts,
            frame_id: "world".into(),
            pose: m::Pose::planar(f.x, f.y, 0.0, f.theta),
        });
    }

    fn write_contact(&mut self, t: u64, c: &mmq_core::ContactSample) {
        let time_s = c.time_s + self.time_offset_s;
        self.write_with(Ch::Contact, ns(time_s), |_| m::Contact {
            t,
            time_s,
            started: c.started,
            wall: c.wall.clone(),
        });
    }
}

/// Heading of a grid move: E 0, N π/2, W π, S −π/2.
fn move_heading(a: usize) -> Option<f64> {
    use std::f64::consts::{FRAC_PI_2, PI};
    Move::from_index(a).map(|m| match m {
        Move::E => 0.0,
        Move::N => FRAC_PI_2,
        Move::W => PI,
        Move::S => -FRAC_PI_2,
    })
}
