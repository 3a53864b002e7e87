//! Integration tests of mmq-robot, one module per topic.
