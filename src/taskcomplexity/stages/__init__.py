"""Stage keys, the content-addressed cache, atomic writes and manifests."""
