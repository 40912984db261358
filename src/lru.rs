//! Least-recently-used lists of shared values: what the renderer keeps
//! between calls (shadow maps, volume solves, response tables, dual
//! scattering's baked tables), each a `Mutex<Vec<(key, Arc<value>)>>`
//! with the most recent entry last.

use std::sync::{Arc, Mutex};

/// The value kept under `key`, now marked the most recent.
pub fn kept<K: PartialEq, V>(list: &Mutex<Vec<(K, Arc<V>)>>, key: &K) -> Option<Arc<V>> {
    let mut c = list.lock().unwrap_or_else(|e| e.into_inner());
    let i = c.iter().position(|e| e.0 == *key)?;
    let e = c.remove(i);
    let v = e.1.clone();
    c.push(e);
    Some(v)
}

/// Keeps `value` under `key` as the most recent of at most `max` entries
/// (the least recent dropped first).
pub fn keep<K, V>(list: &Mutex<Vec<(K, Arc<V>)>>, key: K, value: Arc<V>, max: usize) {
    let mut c = list.lock().unwrap_or_else(|e| e.into_inner());
    c.push((key, value));
    while c.len() > max {
        c.remove(0);
    }
}
