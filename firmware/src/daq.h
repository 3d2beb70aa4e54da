/* The protocol core: commands in, replies and DATA frames out (docs/protocol.md). */
#ifndef EDDI_DAQ_H
#define EDDI_DAQ_H

#include <stdint.h>

#define DAQ_MAX_BLOCK 1024u          /* samples per DATA frame */
#define DAQ_DEFAULT_BLOCK 256u
#define DAQ_FIFO_BYTES (48u * 1024u) /* encoded output FIFO */

void daq_init(void);
void daq_poll(void);                 /* one round of the main loop */

#endif
