file(REMOVE_RECURSE
  "libpano_lut.a"
)
