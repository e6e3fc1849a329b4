/* Custom line rates (SBUS's 100000 bit/s) through termios2: kept apart because the kernel's
 * <asm/termbits.h> and libc's <termios.h> cannot be included together. */
#include <asm/termbits.h>
#include <stdint.h>
#include <sys/ioctl.h>

int posix_set_custom_baud(int fd, uint32_t baud);

int posix_set_custom_baud(int fd, uint32_t baud)
{
    struct termios2 tio;
    if (ioctl(fd, TCGETS2, &tio) < 0)
        return -1;
    tio.c_cflag &= ~(tcflag_t)CBAUD;
    tio.c_cflag |= BOTHER;
    tio.c_ispeed = baud;
    tio.c_ospeed = baud;
    return ioctl(fd, TCSETS2, &tio);
}
