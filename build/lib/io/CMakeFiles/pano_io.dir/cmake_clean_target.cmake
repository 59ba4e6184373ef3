file(REMOVE_RECURSE
  "libpano_io.a"
)
