//! Each camera's eye on a thread of its own: the perceive loop hands a frame to its
//! camera's thread and takes the results back in the order the frames came, so the two
//! cameras' frames are detected at the same time (a Pi has four cores) and what is
//! published is what one thread would have published.
//!
//! An eye holds one frame at a time. The frame, its stage marks' buffer and the result go
//! to the eye's thread and come back by move: nothing of the frame is copied.

use crate::agent::Agent;
use crate::pipeline::{Eye, FrameResult, SharedBall};
use crate::runtime::frame::StoredFrame;
use anyhow::{Context, Result};
use proto::{Camera, Stamp};
use std::collections::VecDeque;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;
use std::time::Instant;
use vision::camera::CameraModel;
use vision::{DetectError, StageClock};

/// A stage's name and its milliseconds.
pub(crate) type Mark = (&'static str, f64);

/// A frame for an eye.
struct Job {
    frame: StoredFrame,
    source_stamp: Stamp,
    model: CameraModel,
    shared: Option<SharedBall>,
    marks: Vec<Mark>,
}

/// A frame back from its eye, with what the eye made of it.
pub(crate) struct Done {
    pub frame: StoredFrame,
    /// The frame's stamp as its source gave it (before `--restamp`).
    pub source_stamp: Stamp,
    pub result: Result<FrameResult, DetectError>,
    /// The pipeline's stages in order, with their times.
    pub marks: Vec<Mark>,
}

/// The two cameras' eyes and their threads.
pub(crate) struct Eyes {
    jobs: [Option<SyncSender<Job>>; 2],
    done: [Receiver<Done>; 2],
    threads: Vec<JoinHandle<()>>,
    /// The cameras of the frames handed over and not yet taken back, oldest first.
    pending: VecDeque<Camera>,
    /// Each eye's marks buffer while the eye is idle.
    spare: [Vec<Mark>; 2],
}

fn index(camera: Camera) -> usize {
    match camera {
        Camera::Left => 0,
        Camera::Right => 1,
    }
}

impl Eyes {
    /// Starts a thread per camera, each with its copy of the agent's eye for it.
    pub fn start(agent: &Agent) -> Result<Eyes> {
        let mut jobs = Vec::new();
        let mut done = Vec::new();
        let mut threads = Vec::new();
        for camera in [Camera::Left, Camera::Right] {
            let (job_tx, job_rx) = sync_channel::<Job>(1);
            let (done_tx, done_rx) = sync_channel::<Done>(1);
            let eye = agent.eye(camera);
            let name = format!("eye-{}", format!("{camera:?}").to_lowercase());
            let thread = std::thread::Builder::new()
                .name(name.clone())
                .spawn(move || see(eye, &job_rx, &done_tx))
                .with_context(|| format!("starting the {name} thread"))?;
            jobs.push(Some(job_tx));
            done.push(done_rx);
            threads.push(thread);
        }
        let [left_rx, right_rx] = <[Receiver<Done>; 2]>::try_from(done)
            .map_err(|_| anyhow::anyhow!("two cameras, two eyes"))?;
        let [left_tx, right_tx] = <[Option<SyncSender<Job>>; 2]>::try_from(jobs)
            .map_err(|_| anyhow::anyhow!("two cameras, two eyes"))?;
        Ok(Eyes {
            jobs: [left_tx, right_tx],
            done: [left_rx, right_rx],
            threads,
            pending: VecDeque::with_capacity(2),
            spare: [Vec::with_capacity(8), Vec::with_capacity(8)],
        })
    }

    /// Whether `camera`'s eye still holds a frame.
    pub fn busy(&self, camera: Camera) -> bool {
        self.pending.contains(&camera)
    }

    /// Hands `frame` to its camera's eye, which must be idle ([`Eyes::busy`]).
    pub fn give(
        &mut self,
        frame: StoredFrame,
        source_stamp: Stamp,
        model: CameraModel,
        shared: Option<SharedBall>,
    ) -> Result<()> {
        let camera = frame.camera;
        let i = index(camera);
        let mut marks = std::mem::take(&mut self.spare[i]);
        marks.clear();
        let job = Job {
            frame,
            source_stamp,
            model,
            shared,
            marks,
        };
        self.jobs[i]
            .as_ref()
            .and_then(|tx| tx.send(job).ok())
            .with_context(|| format!("the {camera:?} camera's eye has stopped"))?;
        self.pending.push_back(camera);
        Ok(())
    }

    /// The oldest frame handed over, back from its eye (waiting for it), or `None` when
    /// the eyes hold none.
    pub fn take_oldest(&mut self) -> Result<Option<Done>> {
        let Some(camera) = self.pending.pop_front() else {
            return Ok(None);
        };
        let done = self.done[index(camera)]
            .recv()
            .with_context(|| format!("the {camera:?} camera's eye has stopped"))?;
        Ok(Some(done))
    }

    /// Gives an eye its marks buffer back once the loop has read it.
    pub fn recycle(&mut self, camera: Camera, marks: Vec<Mark>) {
        self.spare[index(camera)] = marks;
    }
}

impl Drop for Eyes {
    fn drop(&mut self) {
        // Closing the job channels ends the threads' loops.
        self.jobs = [None, None];
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// An eye's thread: frames in, results out, until the loop closes its channel.
fn see(mut eye: Eye, jobs: &Receiver<Job>, done: &SyncSender<Done>) {
    while let Ok(job) = jobs.recv() {
        let Job {
            frame,
            source_stamp,
            model,
            shared,
            marks,
        } = job;
        let mut clock = Marks {
            last: Instant::now(),
            marks,
        };
        let result = eye.look(&frame.input(), &model, shared, &mut clock);
        let back = Done {
            frame,
            source_stamp,
            result,
            marks: clock.marks,
        };
        if done.send(back).is_err() {
            break;
        }
    }
}

/// The stage clock of an eye's thread: each stage's time, in order.
struct Marks {
    last: Instant,
    marks: Vec<Mark>,
}

impl StageClock for Marks {
    fn mark(&mut self, stage: &'static str) {
        let now = Instant::now();
        self.marks
            .push((stage, now.duration_since(self.last).as_secs_f64() * 1e3));
        self.last = now;
    }
}
