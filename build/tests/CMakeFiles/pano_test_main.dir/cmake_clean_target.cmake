file(REMOVE_RECURSE
  "libpano_test_main.a"
)
