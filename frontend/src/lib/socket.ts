import { io, type Socket } from 'socket.io-client';
import type { ServerEvents } from '@/types/events';

type Listeners = { [E in keyof ServerEvents]: (payload: ServerEvents[E]) => void };
interface ClientEvents {
  send_message: (payload: { text: string }, ack: (reply: { ok: boolean; error?: string }) => void) => void;
  stop_pipeline: (payload: null, ack: (reply: { ok: boolean }) => void) => void;
}
export type RobotSocket = Socket<Listeners, ClientEvents>;

let socket: RobotSocket | null = null;

/** The one Socket.IO connection (same origin as the page). */
export function getSocket(): RobotSocket {
  socket ??= io({ path: '/socket.io', transports: ['websocket', 'polling'], autoConnect: false });
  return socket;
}

/** Emit with an acknowledgement and a deadline. */
export function emitWithAck<E extends keyof ClientEvents>(
  event: E,
  payload: Parameters<ClientEvents[E]>[0],
  timeoutMs = 5000,
): Promise<Parameters<Parameters<ClientEvents[E]>[1]>[0]> {
  const s = getSocket();
  return new Promise((resolve, reject) => {
    // eslint-disable-next-line @typescript-eslint/no-explicit-any
    (s.timeout(timeoutMs) as any).emit(event, payload, (err: Error | null, reply: never) =>
      err ? reject(err) : resolve(reply),
    );
  });
}
