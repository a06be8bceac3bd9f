//! Carrying encoded messages: an in-process channel, or UDP to a sound process elsewhere.
