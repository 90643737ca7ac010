/* padapt command-line tool (being written). */
#include "padapt.h"
int main(void) { return 0; }
