# Vertex tracking throughput against decode-only (tools/bench_vertex.sh).
pano_add_benchmark(vertex pano_pipeline pano_render)
