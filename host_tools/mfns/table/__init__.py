"""The binary calibration table (docs/caltable.md): format (writer/reader), grid builder,
default settings, and the test vectors the C tests compare against."""
