//! The `mcap` writer on a thread of its own, so that chunk compression, CRCs and file writes run
//! beside whatever produces the messages (issue 25: a whole-body frame's output is 8 KB, and
//! compressing it is a third of `convert`'s time).
//!
//! The thread makes exactly the calls the caller's thread would have made, in the same order, so
//! the file is byte-identical to one written inline. Messages travel in batches (their headers and
//! one buffer of payloads, about [`BATCH_BYTES`]) through a queue of at most [`QUEUE_BATCHES`]
//! batches: memory stays bounded, and a hand-over costs one wake-up per batch, not per message.
//! Calls that answer something (a schema's or a channel's id, flush, finish) send what is
//! pending and wait for the answer. The first error the thread meets is kept and returned by the
//! next call, so a full disk stops the producer within a few batches, not at the end.

use std::collections::BTreeMap;
use std::io::{Seek, Write};
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;

use mcap::McapError;
use mcap::records::{MessageHeader, Metadata};

use super::Inline;

/// What failed (the action, as [`super::McapIoError::Mcap`] names it) and why.
pub(super) type Failure = (&'static str, McapError);

/// Payload bytes a batch gathers before it is handed over.
const BATCH_BYTES: usize = 64 * 1024;
/// Batches in the queue at most; the producer waits when it is full.
const QUEUE_BATCHES: usize = 4;

/// Messages handed over together: each header with its payload's range in `bytes`.
#[derive(Default)]
struct Batch {
    headers: Vec<(MessageHeader, Range<usize>)>,
    bytes: Vec<u8>,
}

/// An answer: `Err(())` means "the thread has failed; the failure is in the shared slot".
type Reply<T> = Sender<Result<T, ()>>;

enum Command {
    Messages(Batch),
    Metadata(Metadata),
    Schema {
        name: String,
        data: Vec<u8>,
        reply: Reply<u16>,
    },
    Channel {
        schema_id: u16,
        topic: String,
        metadata: BTreeMap<String, String>,
        reply: Reply<u16>,
    },
    Flush(Reply<()>),
    Finish(Reply<()>),
}

/// The first failure of the thread, for the producer to take.
#[derive(Default)]
struct FailureSlot {
    failed: AtomicBool,
    failure: Mutex<Option<Failure>>,
}

impl FailureSlot {
    fn set(&self, failure: Failure) {
        let mut slot = self.failure.lock().unwrap_or_else(PoisonError::into_inner);
        slot.get_or_insert(failure);
        self.failed.store(true, Ordering::Release);
    }

    /// The failure, the first time it is asked for; later, a stand-in that points back at it.
    fn take(&self) -> Failure {
        let mut slot = self.failure.lock().unwrap_or_else(PoisonError::into_inner);
        slot.take().unwrap_or_else(|| {
            (
                "cannot go on writing",
                McapError::Io(std::io::Error::other(
                    "an earlier write to this file failed (reported before)",
                )),
            )
        })
    }
}

/// A `mcap::Writer` running on its own thread.
pub(super) struct WriterThread {
    commands: Option<SyncSender<Command>>,
    /// Batches the thread is done with, to fill again.
    spent: Receiver<Batch>,
    pending: Batch,
    slot: Arc<FailureSlot>,
    thread: Option<JoinHandle<()>>,
}

impl WriterThread {
    /// Moves `writer` onto a new thread.
    ///
    /// # Errors
    /// The operating system's, when it cannot start a thread.
    pub(super) fn spawn<W>(writer: Inline<W>) -> std::io::Result<WriterThread>
    where
        W: Write + Seek + Send + 'static,
    {
        let (commands, inbox) = mpsc::sync_channel(QUEUE_BATCHES);
        let (give_back, spent) = mpsc::channel();
        let slot = Arc::new(FailureSlot::default());
        let thread_slot = Arc::clone(&slot);
        let thread = std::thread::Builder::new()
            .name("mcap-writer".to_string())
            .spawn(move || serve(writer, &inbox, &give_back, &thread_slot))?;
        Ok(WriterThread {
            commands: Some(commands),
            spent,
            pending: Batch::default(),
            slot,
            thread: Some(thread),
        })
    }

    /// Queues one message (the payload is copied into the current batch).
    pub(super) fn write_to_known_channel(
        &mut self,
        header: &MessageHeader,
        payload: &[u8],
    ) -> Result<(), Failure> {
        if self.slot.failed.load(Ordering::Acquire) {
            return Err(self.slot.take());
        }
        let start = self.pending.bytes.len();
        self.pending.bytes.extend_from_slice(payload);
        let range = start..self.pending.bytes.len();
        self.pending.headers.push((*header, range));
        if self.pending.bytes.len() >= BATCH_BYTES {
            self.send_pending()?;
        }
        Ok(())
    }

    pub(super) fn write_metadata(&mut self, metadata: Metadata) -> Result<(), Failure> {
        self.send_pending()?;
        self.send(Command::Metadata(metadata))
    }

    pub(super) fn add_schema(&mut self, name: &str, data: &[u8]) -> Result<u16, Failure> {
        self.ask(|reply| Command::Schema {
            name: name.to_string(),
            data: data.to_vec(),
            reply,
        })
    }

    pub(super) fn add_channel(
        &mut self,
        schema_id: u16,
        topic: &str,
        metadata: &BTreeMap<String, String>,
    ) -> Result<u16, Failure> {
        self.ask(|reply| Command::Channel {
            schema_id,
            topic: topic.to_string(),
            metadata: metadata.clone(),
            reply,
        })
    }

    pub(super) fn flush(&mut self) -> Result<(), Failure> {
        self.ask(Command::Flush)
    }

    /// Finishes the file and ends the thread.
    pub(super) fn finish(&mut self) -> Result<(), Failure> {
        let answer = self.ask(Command::Finish);
        let ended = self.end();
        answer.and(ended)
    }

    /// Hands the pending batch over (if it holds anything) and starts another.
    fn send_pending(&mut self) -> Result<(), Failure> {
        if self.pending.headers.is_empty() {
            return Ok(());
        }
        // A spent batch is filled again, unless a huge message grew it: that one is let go, so
        // a huge message's buffer is not kept for the rest of the file.
        let mut next = self
            .spent
            .try_recv()
            .ok()
            .filter(|b| b.bytes.capacity() <= 4 * BATCH_BYTES)
            .unwrap_or_default();
        next.headers.clear();
        next.bytes.clear();
        let full = std::mem::replace(&mut self.pending, next);
        self.send(Command::Messages(full))
    }

    fn send(&mut self, command: Command) -> Result<(), Failure> {
        if self.slot.failed.load(Ordering::Acquire) {
            return Err(self.slot.take());
        }
        let sent = self.commands.as_ref().map(|c| c.send(command));
        match sent {
            Some(Ok(())) => Ok(()),
            _ => Err(self.stopped()),
        }
    }

    /// Sends what is pending and `command`, and waits for the thread's answer.
    fn ask<T>(&mut self, command: impl FnOnce(Reply<T>) -> Command) -> Result<T, Failure> {
        self.send_pending()?;
        let (reply, answer) = mpsc::channel();
        self.send(command(reply))?;
        match answer.recv() {
            Ok(Ok(value)) => Ok(value),
            Ok(Err(())) => Err(self.slot.take()),
            Err(_) => Err(self.stopped()),
        }
    }

    /// The failure to report when the thread is gone without saying why: its panic.
    fn stopped(&mut self) -> Failure {
        match self.end() {
            Err(failure) => failure,
            Ok(()) => thread_panicked(),
        }
    }

    /// Closes the queue and waits for the thread. Its own failure comes first, then a panic.
    fn end(&mut self) -> Result<(), Failure> {
        self.commands = None;
        let Some(thread) = self.thread.take() else {
            return Ok(());
        };
        let joined = thread.join();
        if self.slot.failed.load(Ordering::Acquire) {
            return Err(self.slot.take());
        }
        joined.map_err(|_| thread_panicked())
    }
}

impl Drop for WriterThread {
    /// Without [`WriterThread::finish`], what is pending is handed over and the thread drops its
    /// writer (which, as inline, ends the file and hides any error); this waits for it, so the
    /// file is closed when the drop returns.
    fn drop(&mut self) {
        let _ = self.send_pending();
        let _ = self.end();
    }
}

fn thread_panicked() -> Failure {
    (
        "the MCAP writer's thread panicked while writing",
        McapError::Io(std::io::Error::other("the writer's thread stopped")),
    )
}

/// The thread: runs commands in order until the queue closes or the file is finished. After a
/// failure it writes nothing more and answers every question with `Err(())`.
fn serve<W: Write + Seek>(
    mut writer: Inline<W>,
    inbox: &Receiver<Command>,
    give_back: &Sender<Batch>,
    slot: &FailureSlot,
) {
    while let Ok(command) = inbox.recv() {
        match command {
            Command::Messages(batch) => {
                let _ = attempt(slot, || {
                    batch.headers.iter().try_for_each(|(header, range)| {
                        writer.write_to_known_channel(header, &batch.bytes[range.clone()])
                    })
                });
                // The producer may have gone; then the batch is simply dropped.
                let _ = give_back.send(batch);
            }
            Command::Metadata(metadata) => {
                let _ = attempt(slot, || writer.write_metadata(&metadata));
            }
            Command::Schema { name, data, reply } => {
                let id = attempt(slot, || writer.add_schema(&name, &data));
                let _ = reply.send(id);
            }
            Command::Channel {
                schema_id,
                topic,
                metadata,
                reply,
            } => {
                let id = attempt(slot, || writer.add_channel(schema_id, &topic, &metadata));
                let _ = reply.send(id);
            }
            Command::Flush(reply) => {
                let _ = reply.send(attempt(slot, || writer.flush()));
            }
            Command::Finish(reply) => {
                let _ = reply.send(attempt(slot, || writer.finish()));
                return;
            }
        }
    }
}

/// `f`'s value; or `Err(())` with its failure put in the slot; or, once the slot holds a
/// failure, `Err(())` without calling `f` (nothing more is written then).
fn attempt<T>(slot: &FailureSlot, f: impl FnOnce() -> Result<T, Failure>) -> Result<T, ()> {
    if slot.failed.load(Ordering::Acquire) {
        return Err(());
    }
    f().map_err(|failure| slot.set(failure))
}
