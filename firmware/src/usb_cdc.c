/* USB CDC-ACM on the STM32F4 OTG_FS core (RM0383 ch. 22), register level, polled.
 *
 * Endpoints: EP0 control (64 bytes), EP1 OUT / EP1 IN bulk (64 bytes, the data), EP2 IN
 * interrupt (CDC notifications, never sent). FIFO RAM (320 words): RX 128, EP0 TX 32,
 * EP1 TX 128, EP2 TX 16. A bulk IN transfer is at most 511 bytes and never a multiple of 64,
 * so it always ends with a short packet and the host's read completes at once.
 * Flow control both ways: EP1 OUT is re-armed only when the receive ring has room for a
 * packet (the host then gets NAKs), and an IN transfer starts only when the previous one is done.
 */
#include "usb_cdc.h"

#include <string.h>

#include "stm32f4.h"

#define GINT_RXFLVL (1u << 4)
#define GINT_USBRST (1u << 12)
#define GINT_ENUMDNE (1u << 13)
#define GINT_IEPINT (1u << 18)
#define GINT_OEPINT (1u << 19)
#define EP_EPENA (1u << 31)
#define EP_SNAK (1u << 27)
#define EP_CNAK (1u << 26)
#define EP_SD0PID (1u << 28)
#define EP_STALL (1u << 21)
#define EP_USBAEP (1u << 15)
#define EPINT_XFRC (1u << 0)
#define EPINT_STUP (1u << 3)

static const uint8_t DEVICE_DESC[18] = {
    18, 1, 0x00, 0x02, 0x02, 0x00, 0x00, 64,
    (uint8_t)USB_VID, (uint8_t)(USB_VID >> 8), (uint8_t)USB_PID, (uint8_t)(USB_PID >> 8),
    0x00, 0x01, 1, 2, 3, 1,
};

static const uint8_t CONFIG_DESC[67] = {
    9, 2, 67, 0, 2, 1, 0, 0x80, 50,
    9, 4, 0, 0, 1, 0x02, 0x02, 0x01, 0,         /* CDC communication interface, AT-less ACM */
    5, 0x24, 0x00, 0x10, 0x01,                  /* header */
    5, 0x24, 0x01, 0x00, 1,                     /* call management */
    4, 0x24, 0x02, 0x02,                        /* ACM: line coding, control line state */
    5, 0x24, 0x06, 0, 1,                        /* union: 0 controls 1 */
    7, 5, 0x82, 0x03, 16, 0, 16,                /* EP2 IN interrupt */
    9, 4, 1, 0, 2, 0x0A, 0x00, 0x00, 0,         /* CDC data interface */
    7, 5, 0x01, 0x02, 64, 0, 0,                 /* EP1 OUT bulk */
    7, 5, 0x81, 0x02, 64, 0, 0,                 /* EP1 IN bulk */
};

static const char *const STRINGS[] = {"", "EDDI Station (open hardware)", "EDDI DAQ F411 + ADS131M04", ""};

static struct {
    const char *serial;
    uint8_t setup[8];
    uint8_t ep0_buf[64];
    uint8_t line_coding[7];
    int configured;
    int tx_busy;
    int out_paused;
    uint8_t rx[512];
    uint32_t rx_head, rx_tail;
} u;

static void delay(volatile uint32_t n)
{
    while (n--) {
    }
}

static void fifo_write(unsigned ep, const uint8_t *p, size_t n)
{
    for (size_t i = 0; i < n; i += 4) {
        uint32_t w = 0;
        for (size_t k = 0; k < 4 && i + k < n; k++)
            w |= (uint32_t)p[i + k] << (8u * k);
        OTG_FIFO(ep) = w;
    }
}

static void fifo_read(uint8_t *p, size_t n)
{
    for (size_t i = 0; i < n; i += 4) {
        uint32_t w = OTG_FIFO(0);
        for (size_t k = 0; k < 4 && i + k < n; k++)
            if (p)
                p[i + k] = (uint8_t)(w >> (8u * k));
    }
}

static void ep0_out_arm(void)
{
    OTG_DOEPTSIZ(0) = (3u << 29) | (1u << 19) | 64u;
    OTG_DOEPCTL(0) |= EP_EPENA | EP_CNAK;
}

static void ep1_out_arm(void)
{
    if (sizeof u.rx - (u.rx_head - u.rx_tail) < 64u) {
        u.out_paused = 1;      /* host gets NAKs until the ring drains */
        return;
    }
    u.out_paused = 0;
    OTG_DOEPTSIZ(1) = (1u << 19) | 64u;
    OTG_DOEPCTL(1) |= EP_EPENA | EP_CNAK;
}

static void ep0_send(const uint8_t *p, size_t n, uint16_t max)
{
    if (n > max)
        n = max;
    uint32_t pkts = n ? (uint32_t)((n + 63u) / 64u) : 1u;
    OTG_DIEPTSIZ(0) = (pkts << 19) | (uint32_t)n;
    OTG_DIEPCTL(0) |= EP_EPENA | EP_CNAK;
    fifo_write(0, p, n);
}

static void ep0_stall(void)
{
    OTG_DIEPCTL(0) |= EP_STALL;
    OTG_DOEPCTL(0) |= EP_STALL;
}

static void send_string(unsigned index, uint16_t max)
{
    uint8_t d[64];
    size_t n = 2;
    if (index == 0) {
        d[2] = 0x09;            /* English (US) */
        d[3] = 0x04;
        n = 4;
    } else {
        const char *s = index == 3 ? u.serial : STRINGS[index];
        for (; *s && n + 2 <= sizeof d; s++) {
            d[n++] = (uint8_t)*s;
            d[n++] = 0;
        }
    }
    d[0] = (uint8_t)n;
    d[1] = 3;
    ep0_send(d, n, max);
}

static void configure_endpoints(void)
{
    OTG_DIEPCTL(1) = EP_USBAEP | (2u << 18) | 64u | (1u << 22) | EP_SD0PID;
    OTG_DOEPCTL(1) = EP_USBAEP | (2u << 18) | 64u | EP_SD0PID;
    OTG_DIEPCTL(2) = EP_USBAEP | (3u << 18) | 16u | (2u << 22) | EP_SD0PID;
    u.configured = 1;
    u.tx_busy = 0;
    ep1_out_arm();
}

static void handle_setup(void)
{
    uint8_t type = u.setup[0], req = u.setup[1];
    uint16_t value = (uint16_t)(u.setup[2] | (u.setup[3] << 8));
    uint16_t length = (uint16_t)(u.setup[6] | (u.setup[7] << 8));
    static const uint8_t zero2[2] = {0, 0};
    if ((type & 0x60u) == 0x00u) {                       /* standard */
        switch (req) {
        case 6:                                          /* GET_DESCRIPTOR */
            if ((value >> 8) == 1)
                ep0_send(DEVICE_DESC, sizeof DEVICE_DESC, length);
            else if ((value >> 8) == 2)
                ep0_send(CONFIG_DESC, sizeof CONFIG_DESC, length);
            else if ((value >> 8) == 3 && (value & 0xFFu) < 4u)
                send_string(value & 0xFFu, length);
            else
                ep0_stall();
            break;
        case 5:                                          /* SET_ADDRESS */
            OTG_DCFG = (OTG_DCFG & ~(0x7Fu << 4)) | ((uint32_t)(value & 0x7Fu) << 4);
            ep0_send(0, 0, 0);
            break;
        case 9:                                          /* SET_CONFIGURATION */
            if (value == 1)
                configure_endpoints();
            else
                u.configured = 0;
            ep0_send(0, 0, 0);
            break;
        case 8: {                                        /* GET_CONFIGURATION */
            uint8_t c = (uint8_t)u.configured;
            ep0_send(&c, 1, length);
            break;
        }
        case 0:                                          /* GET_STATUS */
            ep0_send(zero2, 2, length);
            break;
        case 1:                                          /* CLEAR_FEATURE */
        case 11:                                         /* SET_INTERFACE */
            ep0_send(0, 0, 0);
            break;
        default:
            ep0_stall();
        }
    } else if ((type & 0x60u) == 0x20u) {                /* CDC class */
        switch (req) {
        case 0x20:                                       /* SET_LINE_CODING: 7 bytes follow */
            break;
        case 0x21:                                       /* GET_LINE_CODING */
            ep0_send(u.line_coding, sizeof u.line_coding, length);
            break;
        case 0x22:                                       /* SET_CONTROL_LINE_STATE */
            ep0_send(0, 0, 0);
            break;
        default:
            ep0_stall();
        }
    } else {
        ep0_stall();
    }
    ep0_out_arm();
}

static void usb_reset(void)
{
    for (unsigned i = 0; i < 4u; i++) {
        OTG_DOEPCTL(i) |= EP_SNAK;
        OTG_DOEPINT(i) = 0xFFu;
        OTG_DIEPINT(i) = 0xFFu;
    }
    OTG_DAINTMSK = (1u << 0) | (1u << 1) | (1u << 16) | (1u << 17);
    OTG_DOEPMSK = EPINT_XFRC | EPINT_STUP;
    OTG_DIEPMSK = EPINT_XFRC;
    OTG_DCFG &= ~(0x7Fu << 4);
    u.configured = 0;
    u.tx_busy = 0;
    ep0_out_arm();
}

static void handle_rx_status(void)
{
    uint32_t s = OTG_GRXSTSP;
    unsigned ep = s & 0xFu, bcnt = (s >> 4) & 0x7FFu, pktsts = (s >> 17) & 0xFu;
    if (pktsts == 6u) {                                  /* SETUP data */
        fifo_read(u.setup, 8);
    } else if (pktsts == 2u && bcnt) {                   /* OUT data */
        if (ep == 1u) {
            uint8_t tmp[64];
            fifo_read(tmp, bcnt);
            for (unsigned i = 0; i < bcnt; i++)
                u.rx[u.rx_head++ % sizeof u.rx] = tmp[i];
        } else {
            fifo_read(u.ep0_buf, bcnt > 64u ? 64u : bcnt);
            if (u.setup[1] == 0x20u && bcnt >= 7u) {     /* the line coding: kept, not used */
                memcpy(u.line_coding, u.ep0_buf, 7);
                ep0_send(0, 0, 0);
            }
        }
    }
}

void usb_cdc_init(const char *serial)
{
    static const uint8_t coding[7] = {0x00, 0x10, 0x0E, 0x00, 0, 0, 8};   /* 921600 8N1 */
    memset(&u, 0, sizeof u);
    u.serial = serial;
    memcpy(u.line_coding, coding, sizeof coding);
    RCC_AHB1ENR |= 1u << 0;                              /* GPIOA */
    RCC_AHB2ENR |= 1u << 7;                              /* OTG FS */
    /* PA11 (DM), PA12 (DP): AF10, very high speed */
    GPIO_MODER(GPIOA_BASE) = (GPIO_MODER(GPIOA_BASE) & ~(0xFu << 22)) | (0xAu << 22);
    GPIO_OSPEEDR(GPIOA_BASE) |= 0xFu << 22;
    GPIO_AFRH(GPIOA_BASE) = (GPIO_AFRH(GPIOA_BASE) & ~(0xFFu << 12)) | (0xAAu << 12);
    OTG_GUSBCFG |= 1u << 6;                              /* the embedded FS PHY */
    while (!(OTG_GRSTCTL & (1u << 31))) {
    }
    OTG_GRSTCTL |= 1u;                                   /* core soft reset */
    while (OTG_GRSTCTL & 1u) {
    }
    OTG_GUSBCFG = (OTG_GUSBCFG & ~(0xFu << 10)) | (1u << 30) | (6u << 10) | (1u << 6);
    delay(100000);                                       /* forced device mode takes 25 ms */
    OTG_GCCFG = (1u << 16) | (1u << 21);                 /* PHY on, no VBUS sensing */
    OTG_PCGCCTL = 0;
    OTG_DCFG = (OTG_DCFG & ~3u) | 3u;                    /* full speed */
    OTG_GRXFSIZ = 128u;
    OTG_DIEPTXF0 = (32u << 16) | 128u;
    OTG_DIEPTXF(1) = (128u << 16) | 160u;
    OTG_DIEPTXF(2) = (16u << 16) | 288u;
    OTG_GRSTCTL = (1u << 5) | (0x10u << 6);              /* flush every TX FIFO */
    while (OTG_GRSTCTL & (1u << 5)) {
    }
    OTG_GRSTCTL = 1u << 4;                               /* flush the RX FIFO */
    while (OTG_GRSTCTL & (1u << 4)) {
    }
    OTG_GINTSTS = 0xFFFFFFFFu;
    OTG_GINTMSK = GINT_RXFLVL | GINT_USBRST | GINT_ENUMDNE | GINT_IEPINT | GINT_OEPINT;
    OTG_DCTL &= ~(1u << 1);                              /* soft connect */
}

void usb_cdc_poll(void)
{
    uint32_t st = OTG_GINTSTS;
    if (st & GINT_USBRST) {
        OTG_GINTSTS = GINT_USBRST;
        usb_reset();
    }
    if (st & GINT_ENUMDNE) {
        OTG_GINTSTS = GINT_ENUMDNE;
        OTG_DIEPCTL(0) &= ~3u;                           /* EP0: 64 bytes */
        OTG_DCTL |= 1u << 8;                             /* clear global IN NAK */
    }
    while (OTG_GINTSTS & GINT_RXFLVL)
        handle_rx_status();
    if (st & GINT_OEPINT) {
        uint32_t daint = OTG_DAINT;
        if (daint & (1u << 16)) {
            uint32_t i = OTG_DOEPINT(0);
            OTG_DOEPINT(0) = i;
            if (i & EPINT_STUP)
                handle_setup();
            else if (i & EPINT_XFRC)
                ep0_out_arm();
        }
        if (daint & (1u << 17)) {
            uint32_t i = OTG_DOEPINT(1);
            OTG_DOEPINT(1) = i;
            if (i & EPINT_XFRC)
                ep1_out_arm();
        }
    }
    if (st & GINT_IEPINT) {
        uint32_t daint = OTG_DAINT;
        if (daint & 1u)
            OTG_DIEPINT(0) = OTG_DIEPINT(0);
        if (daint & 2u) {
            uint32_t i = OTG_DIEPINT(1);
            OTG_DIEPINT(1) = i;
            if (i & EPINT_XFRC)
                u.tx_busy = 0;
        }
    }
    if (u.configured && u.out_paused)
        ep1_out_arm();
}

int usb_cdc_read(uint8_t *b)
{
    if (u.rx_head == u.rx_tail)
        return 0;
    *b = u.rx[u.rx_tail++ % sizeof u.rx];
    return 1;
}

size_t usb_cdc_write(const uint8_t *p, size_t n)
{
    if (!u.configured || u.tx_busy || !n)
        return 0;
    if (n > 511u)
        n = 511u;
    if (n % 64u == 0u)
        n -= 1u;                                         /* end on a short packet */
    if (OTG_DTXFSTS(1) < (n + 3u) / 4u)
        return 0;
    uint32_t pkts = (uint32_t)((n + 63u) / 64u);
    OTG_DIEPTSIZ(1) = (pkts << 19) | (uint32_t)n;
    OTG_DIEPCTL(1) |= EP_EPENA | EP_CNAK;
    fifo_write(1, p, n);
    u.tx_busy = 1;
    return n;
}
