//! A latest-value mailbox for state snapshots (robot position for the Simulator Manager and
//! the GUI): the writer publishes, the reader sees the newest value; neither ever waits, and
//! older values are overwritten, not queued. A thin layer over [`triple_buffer`].

/// A mailbox holding `initial` until the first write: the writing and the reading end.
///
/// ```
/// let (mut w, mut r) = wrc_rt::ipc::mailbox([0.0f64; 4]);
/// w.write([1.0, 2.0, 3.0, 4.0]);
/// w.write([5.0, 6.0, 7.0, 8.0]);
/// assert_eq!(r.read(), &[5.0, 6.0, 7.0, 8.0]);
/// ```
pub fn mailbox<T: Clone + Send>(initial: T) -> (MailboxWriter<T>, MailboxReader<T>) {
    let (input, output) = triple_buffer::TripleBuffer::new(&initial).split();
    (MailboxWriter { input }, MailboxReader { output })
}

/// The writing end (one thread).
pub struct MailboxWriter<T: Send> {
    input: triple_buffer::Input<T>,
}

impl<T: Send> MailboxWriter<T> {
    /// Publish `value`, replacing whatever was not read yet. Wait-free; moves, never allocates.
    pub fn write(&mut self, value: T) {
        self.input.write(value);
    }
}

/// The reading end (one thread).
pub struct MailboxReader<T: Send> {
    output: triple_buffer::Output<T>,
}

impl<T: Send> MailboxReader<T> {
    /// The newest published value. Wait-free.
    pub fn read(&mut self) -> &T {
        self.output.read()
    }

    /// A value was published since the last [`MailboxReader::read`].
    pub fn has_update(&self) -> bool {
        self.output.updated()
    }
}

impl<T: Send> std::fmt::Debug for MailboxWriter<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("MailboxWriter")
    }
}

impl<T: Send> std::fmt::Debug for MailboxReader<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("MailboxReader")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reader_sees_the_latest_consistent_value() {
        let (mut w, mut r) = mailbox([0u64; 16]);
        assert!(!r.has_update());
        let writer = std::thread::spawn(move || {
            for i in 1..=100_000u64 {
                w.write([i; 16]);
            }
        });
        let mut last = 0;
        while !writer.is_finished() || r.has_update() {
            let v = *r.read();
            assert!(v.iter().all(|&x| x == v[0]), "torn snapshot {v:?}");
            assert!(v[0] >= last);
            last = v[0];
        }
        writer.join().unwrap();
        assert_eq!(r.read()[0], 100_000);
    }
}
