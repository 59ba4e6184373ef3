file(REMOVE_RECURSE
  "libpano_sensor.a"
)
