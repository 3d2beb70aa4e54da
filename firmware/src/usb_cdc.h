/* USB CDC-ACM device on the STM32F4 OTG_FS core, polled from the main loop (no vendor stack).
 * The host sees a serial port (/dev/ttyACM0) carrying the protocol's byte stream. */
#ifndef EDDI_USB_CDC_H
#define EDDI_USB_CDC_H

#include <stddef.h>
#include <stdint.h>

#define USB_VID 0x1209u   /* pid.codes */
#define USB_PID 0xEDD2u   /* CDC variant of the EDDI DAQ (the vendor-class one is EDD1) */

void usb_cdc_init(const char *serial);
void usb_cdc_poll(void);
int usb_cdc_read(uint8_t *b);                       /* 1 when a byte was read */
size_t usb_cdc_write(const uint8_t *p, size_t n);   /* bytes taken (0 while busy / unconfigured) */

#endif
