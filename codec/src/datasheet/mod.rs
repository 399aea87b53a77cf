//! DataSheet service (chapter 5): packet header, deframer and JSON payload.
