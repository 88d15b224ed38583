"""A minimal gdabench plugin: the example of the plugin guide (docs/plugins.md)."""
