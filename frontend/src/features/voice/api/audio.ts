import { apiPost } from '@/lib/api-client';

export interface AudioTurn {
  transcript: string;
  reply: string;
}

/** One push-to-talk recording → the brain's speech input → a normal turn. */
export function sendAudio(recording: Blob): Promise<AudioTurn> {
  return apiPost<AudioTurn>('/api/chat/audio', recording, recording.type || 'audio/webm');
}
