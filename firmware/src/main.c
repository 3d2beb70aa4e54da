/* EDDI DAQ firmware: the protocol core over whichever board it was built for. */
#include "board.h"
#include "daq.h"

int main(void)
{
    board_init();
    daq_init();
    for (;;)
        daq_poll();
}
