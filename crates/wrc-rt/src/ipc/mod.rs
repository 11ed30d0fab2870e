//! Inter-task communication, the paper's Table 5 kinds and two more a controller needs; all
//! allocation-free after creation.
//!
//! | kind | use | real-time side |
//! |---|---|---|
//! | [`Semaphore`] | events, "work is ready" | `post` is lock-free from any thread |
//! | [`MessageQueue`] | commands between tasks | `try_send` hands the message back when full; made with [`MessageQueue::with_notify`], every send also releases the consumer task at once ([`crate::wake`]) |
//! | [`spsc`] | per-period pulse batches | wait-free push/pop (rtrb) |
//! | [`mailbox`] | latest state snapshot | wait-free write/read (triple buffer) |

pub mod mailbox;
pub mod queue;
pub mod semaphore;
pub mod spsc;

pub use mailbox::{mailbox, MailboxReader, MailboxWriter};
pub use queue::{MessageQueue, RecvError, TrySendError};
pub use semaphore::Semaphore;
pub use spsc::{Full, SpscReceiver, SpscSender};
