//! Work done ahead, in order: `Prefetch` runs a job per index (reading and decoding a scene
//! file, for `render --out-dir`) on a few threads while the caller consumes the results one by
//! one in index order. A job starts only while fewer than `ahead` results are waiting or being
//! made beyond the one the caller took last, so a batch of large files holds at most `ahead`
//! decoded scenes besides the one rendering, however slow one of them is.

use std::collections::BTreeMap;
use std::panic::AssertUnwindSafe;
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;

struct State<T> {
    /// The next index a thread will start.
    next: usize,
    /// Results the caller has taken.
    taken: usize,
    ready: BTreeMap<usize, std::thread::Result<T>>,
    stop: bool,
}

pub struct Prefetch<T> {
    count: usize,
    shared: Arc<(Mutex<State<T>>, Condvar)>,
    threads: Vec<JoinHandle<()>>,
}

impl<T: Send + 'static> Prefetch<T> {
    /// Starts `job(0..count)` on `ahead` threads (at least one), `ahead` at most in flight.
    pub fn new(count: usize, ahead: usize, job: impl Fn(usize) -> T + Send + Sync + 'static) -> Self {
        let ahead = ahead.max(1);
        let state = State { next: 0, taken: 0, ready: BTreeMap::new(), stop: false };
        let shared = Arc::new((Mutex::new(state), Condvar::new()));
        let job = Arc::new(job);
        let threads = (0..ahead.min(count))
            .map(|_| {
                let (shared, job) = (shared.clone(), job.clone());
                std::thread::spawn(move || {
                    let (lock, wake) = &*shared;
                    loop {
                        let index = {
                            let mut s = lock.lock().expect("no panics while holding the lock");
                            while !s.stop && s.next < count && s.next >= s.taken + ahead {
                                s = wake.wait(s).expect("no panics while holding the lock");
                            }
                            if s.stop || s.next >= count {
                                return;
                            }
                            s.next += 1;
                            s.next - 1
                        };
                        // A panicking job is the caller's error for that index, not a hang.
                        let result = std::panic::catch_unwind(AssertUnwindSafe(|| job(index)));
                        lock.lock().expect("no panics while holding the lock").ready.insert(index, result);
                        wake.notify_all();
                    }
                })
            })
            .collect();
        Self { count, shared, threads }
    }
}

impl<T> Iterator for Prefetch<T> {
    /// The next result in index order, waited for; `Err` where its job panicked.
    type Item = Result<T, String>;

    fn next(&mut self) -> Option<Self::Item> {
        let (lock, wake) = &*self.shared;
        let mut s = lock.lock().expect("no panics while holding the lock");
        if s.taken >= self.count {
            return None;
        }
        let index = s.taken;
        let result = loop {
            if let Some(r) = s.ready.remove(&index) {
                break r;
            }
            s = wake.wait(s).expect("no panics while holding the lock");
        };
        s.taken += 1;
        wake.notify_all();
        Some(result.map_err(|_| format!("job {index} panicked")))
    }
}

impl<T> Drop for Prefetch<T> {
    /// Stops starting jobs and waits for those running.
    fn drop(&mut self) {
        let (lock, wake) = &*self.shared;
        lock.lock().expect("no panics while holding the lock").stop = true;
        wake.notify_all();
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    #[test]
    fn results_come_in_order_and_no_more_than_ahead_run_beyond_the_last_taken() {
        let running = Arc::new(AtomicUsize::new(0));
        let most = Arc::new(AtomicUsize::new(0));
        let (r, m) = (running.clone(), most.clone());
        let mut p = Prefetch::new(12, 3, move |i| {
            let now = r.fetch_add(1, Ordering::SeqCst) + 1;
            m.fetch_max(now, Ordering::SeqCst);
            // Later jobs finish first: order must come from the index, not the finish.
            std::thread::sleep(std::time::Duration::from_millis(((12 - i) * 2) as u64));
            r.fetch_sub(1, Ordering::SeqCst);
            if i == 5 {
                panic!("job 5 fails");
            }
            i * 10
        });
        let mut got = Vec::new();
        for (i, r) in p.by_ref().enumerate() {
            match r {
                Ok(v) => got.push(v),
                Err(e) => assert!(i == 5 && e.contains("job 5 panicked"), "{e}"),
            }
            std::thread::sleep(std::time::Duration::from_millis(3));
        }
        assert_eq!(got, [0, 10, 20, 30, 40, 60, 70, 80, 90, 100, 110]);
        assert!(most.load(Ordering::SeqCst) <= 3, "at most three at once");
    }

    #[test]
    fn dropping_it_early_stops_the_threads() {
        let started = Arc::new(AtomicUsize::new(0));
        let s = started.clone();
        let mut p = Prefetch::new(1000, 2, move |i| {
            s.fetch_add(1, Ordering::SeqCst);
            i
        });
        assert_eq!(p.next().unwrap().unwrap(), 0);
        drop(p);
        assert!(started.load(Ordering::SeqCst) <= 4, "no more than the ones ahead started");
    }
}
