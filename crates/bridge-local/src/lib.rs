//! # bridge-local: a bridge on a thread, in a setup of its own
//!
//! A host bridge on a thread of this process ([`LocalBridge`]), in an iceoryx2
//! setup of its own ([`Isolated`]: a unique file prefix and root directory,
//! swept when dropped): for tests, benchmarks and examples that must never meet
//! another run's services. A dev-dependency only (`cargo xtask test`'s layering
//! stage checks that no crate depends on it otherwise).
//!
//! [`netns`]: two hosts on one machine (network namespaces and a veth pair)
//! for the bridge across hosts.
#![deny(missing_docs)]

pub mod netns;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use decoy_config::SystemConfig;
use iceoryx2::config::Config;

use host_bridge::BridgeError;
use host_bridge::backend::{Backend, BackendOptions, host_backend};
use host_bridge::bridge::{BridgeOptions, BridgeSummary, run_bridge};
use host_bridge::services::{PREFIX_ENV, ROOT_ENV, iox_config};

/// Stack of a bridge thread (the solver's fixed-capacity arrays are values).
pub const BRIDGE_STACK_BYTES: usize = 64 << 20;

/// An iceoryx2 setup of its own: prefix `dcy<pid>x<n>_`, root a fresh directory
/// under the system's temporary directory. Dropping it removes the root
/// directory and every `/dev/shm` file with its prefix.
pub struct Isolated {
    /// The file prefix.
    pub prefix: String,
    /// The root directory.
    pub root: PathBuf,
    /// The configuration with both.
    pub config: Config,
}

impl Isolated {
    /// A fresh setup.
    pub fn new() -> Result<Self, BridgeError> {
        static NEXT: AtomicU32 = AtomicU32::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let prefix = format!("dcy{}x{n}_", std::process::id());
        let root = std::env::temp_dir().join(format!("decoy-iox-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&root)
            .map_err(|e| BridgeError::Ipc(format!("cannot create {}: {e}", root.display())))?;
        let config = iox_config(Some(&prefix), Some(&root.display().to_string()))?;
        Ok(Isolated {
            prefix,
            root,
            config,
        })
    }

    /// The environment a `decoy` process needs to join this setup.
    pub fn env(&self) -> [(&'static str, String); 2] {
        [
            (PREFIX_ENV, self.prefix.clone()),
            (ROOT_ENV, self.root.display().to_string()),
        ]
    }

    /// Files of this setup in `/dev/shm` and under the root (what a clean
    /// shutdown should have removed), but iceoryx2's global management file.
    pub fn leftovers(&self) -> Vec<PathBuf> {
        let mut found = shm_files(&self.prefix);
        found.retain(|p| !p.to_string_lossy().ends_with("global_mgmt"));
        collect_files(&self.root, &mut found);
        found
    }
}

fn shm_files(prefix: &str) -> Vec<PathBuf> {
    std::fs::read_dir("/dev/shm")
        .map(|d| {
            d.flatten()
                .map(|e| e.path())
                .filter(|p| {
                    p.file_name()
                        .is_some_and(|n| n.to_string_lossy().starts_with(prefix))
                })
                .collect()
        })
        .unwrap_or_default()
}

fn collect_files(dir: &Path, out: &mut Vec<PathBuf>) {
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                collect_files(&p, out);
            } else {
                out.push(p);
            }
        }
    }
}

impl Drop for Isolated {
    fn drop(&mut self) {
        for f in shm_files(&self.prefix) {
            let _ = std::fs::remove_file(f);
        }
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

/// A bridge running on a thread until [`LocalBridge::stop`] (or drop).
pub struct LocalBridge {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<Result<BridgeSummary, BridgeError>>>,
}

impl LocalBridge {
    /// Starts bridge `instance` with the host backend `backend` (the
    /// controller in this process) in `config`'s setup; see
    /// [`LocalBridge::start_with`].
    pub fn start(
        instance: &str,
        system: &SystemConfig,
        backend: &BackendOptions,
        config: &Config,
    ) -> Result<Self, BridgeError> {
        let system = system.clone();
        let backend = backend.clone();
        Self::start_with(instance, config, move || host_backend(&system, &backend))
    }

    /// Starts bridge `instance` in `config`'s setup with the backend `make`
    /// builds (on the bridge's thread, whose stack holds a large solver: see
    /// [`BRIDGE_STACK_BYTES`]) and returns once it is ready: every service and
    /// port exists, the `status` service (the clients' readiness mark,
    /// `host_bridge::services`) last.
    pub fn start_with(
        instance: &str,
        config: &Config,
        make: impl FnOnce() -> Result<Box<dyn Backend + Send>, BridgeError> + Send + 'static,
    ) -> Result<Self, BridgeError> {
        let stop = Arc::new(AtomicBool::new(false));
        let (ready_tx, ready_rx) = std::sync::mpsc::channel::<Result<(), String>>();
        let options = BridgeOptions {
            instance: instance.to_owned(),
            config: config.clone(),
            status_line: false,
            stop: Some(stop.clone()),
        };
        let thread = std::thread::Builder::new()
            .name(format!("bridge-{instance}"))
            .stack_size(BRIDGE_STACK_BYTES)
            .spawn(move || {
                let b = match make() {
                    Ok(b) => b,
                    Err(e) => {
                        let _ = ready_tx.send(Err(e.to_string()));
                        return Err(e);
                    }
                };
                let tx = ready_tx.clone();
                let result = run_bridge(&options, b, move |_| {
                    let _ = tx.send(Ok(()));
                });
                if let Err(e) = &result {
                    let _ = ready_tx.send(Err(e.to_string()));
                }
                result
            })
            .map_err(|e| BridgeError::Ipc(format!("cannot start the bridge thread: {e}")))?;
        match ready_rx.recv_timeout(Duration::from_secs(600)) {
            Ok(Ok(())) => Ok(LocalBridge {
                stop,
                thread: Some(thread),
            }),
            Ok(Err(e)) => {
                let _ = thread.join();
                Err(BridgeError::Ipc(e))
            }
            Err(_) => Err(BridgeError::Ipc("the bridge did not start".to_owned())),
        }
    }

    /// Stops the bridge and returns its summary.
    pub fn stop(mut self) -> Result<BridgeSummary, BridgeError> {
        self.finish()
    }

    fn finish(&mut self) -> Result<BridgeSummary, BridgeError> {
        self.stop.store(true, Ordering::Relaxed);
        match self.thread.take() {
            Some(t) => t
                .join()
                .unwrap_or_else(|_| Err(BridgeError::Ipc("the bridge thread panicked".to_owned()))),
            None => Err(BridgeError::Ipc("already stopped".to_owned())),
        }
    }
}

impl Drop for LocalBridge {
    fn drop(&mut self) {
        if self.thread.is_some() {
            let _ = self.finish();
        }
    }
}

/// The controller's own time per frame in this process, median over
/// `frames` after the first (the trim), us: the host backend of `options`
/// alone, on a thread with the bridge's stack (the benchmarks' "solver p50").
pub fn controller_time_p50(
    config: &SystemConfig,
    options: &BackendOptions,
    frames: &[decoy_link::AircraftStateFrame],
) -> Result<f64, BridgeError> {
    use decoy_link::{Command, HostMessage};
    let (config, options, frames) = (config.clone(), options.clone(), frames.to_vec());
    std::thread::Builder::new()
        .stack_size(BRIDGE_STACK_BYTES)
        .spawn(move || -> Result<f64, BridgeError> {
            let mut b = host_backend(&config, &options)?;
            b.handle(HostMessage::Command(Command::ResetToTrim))?;
            let Some((first, rest)) = frames.split_first() else {
                return Ok(0.0);
            };
            b.handle(HostMessage::State(*first))?;
            let mut t = Vec::with_capacity(rest.len());
            for f in rest {
                let t0 = std::time::Instant::now();
                b.handle(HostMessage::State(*f))?;
                t.push(t0.elapsed().as_secs_f64() * 1e6);
            }
            Ok(host_bridge::timing::Percentiles::of(&mut t).p50)
        })
        .map_err(|e| BridgeError::Backend(format!("cannot start a thread: {e}")))?
        .join()
        .map_err(|_| BridgeError::Backend("the controller's thread panicked".to_owned()))?
}
