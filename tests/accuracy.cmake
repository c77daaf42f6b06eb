# The accuracy metric (bench/accuracy.c): hand-checkable cases.
ch_add_test(NAME test_accuracy SOURCES test_accuracy.c LIBS chisel_accuracy)
