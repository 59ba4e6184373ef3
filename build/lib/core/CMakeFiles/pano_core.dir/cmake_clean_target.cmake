file(REMOVE_RECURSE
  "libpano_core.a"
)
