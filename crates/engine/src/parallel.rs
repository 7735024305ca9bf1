//! Data parallelism without a thread pool: scoped threads over a job list. Used where work is
//! coarse and independent (image decoding, mip generation), which on a 2-core machine is the
//! bulk of a scene's load time.

/// Runs `jobs` on up to `available_parallelism` threads, keeping their order.
pub fn parallel_map<T: Sync, R: Send>(jobs: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(jobs.len()).max(1);
    if threads == 1 {
        return jobs.iter().map(f).collect();
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut results: Vec<Option<R>> = (0..jobs.len()).map(|_| None).collect();
    let slots = std::sync::Mutex::new(&mut results);
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(job) = jobs.get(i) else { break };
                    let r = f(job);
                    slots.lock().expect("no panics while holding the lock")[i] = Some(r);
                }
            });
        }
    });
    results.into_iter().map(|r| r.expect("every job ran")).collect()
}
