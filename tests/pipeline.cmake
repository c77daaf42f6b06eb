# The pipeline (src/pipeline): one call per job, checked against the stages.
ch_add_test(NAME test_pipeline SOURCES test_pipeline.c LIBS chisel_pipeline m)
